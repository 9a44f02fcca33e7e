"""Learning tracking policies from the sampling MPC (``mjchar learn``): DAgger with DART noise
(:mod:`.dagger`), episodes and labels on worker processes (:mod:`.collect`), PyTorch training
behind the ``rl`` extra (:mod:`.train`), the learning curve (:mod:`.curve`). Running a learned
policy needs none of this: :mod:`mjchar.controllers.learned`."""
