"""Walking controllers: SIMBICON (Yin et al. 2007) with its gaits as data, and IPM stepping
(Coros et al. 2010) with swing-foot trajectories. Registered as ``simbicon`` and ``ipm``."""

# Registration order: simbicon, then ipm:
# isort: off
from .simbicon import Simbicon, SimbiconModelError, make_simbicon
from .ipm import IPMController, IPMError, IPMParams, ipm_step_offset, make_ipm
# isort: on
from .gaits import GAITS, Gait, GaitError, get_gait
from .swing import SwingError, SwingTrajectory, two_link_ik

__all__ = ["GAITS", "Gait", "GaitError", "IPMController", "IPMError", "IPMParams", "Simbicon",
           "SimbiconModelError", "SwingError", "SwingTrajectory", "get_gait", "ipm_step_offset",
           "make_ipm", "make_simbicon", "two_link_ik"]
