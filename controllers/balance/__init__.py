"""Balance controllers: hand-of-god (a PD tracker plus an external root wrench) and static
balance (stable PD plus a centre-of-mass virtual force, no root force). Registered as
``hand_of_god`` and ``static_balance``."""

from .hand_of_god import HandOfGod, make_hand_of_god
from .static_balance import StaticBalance, make_static_balance, squat_profile

__all__ = ["HandOfGod", "StaticBalance", "make_hand_of_god", "make_static_balance",
           "squat_profile"]
