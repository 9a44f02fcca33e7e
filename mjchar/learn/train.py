"""Supervised training of the policy network on the aggregated labels (PyTorch, CPU).

PyTorch is imported here only: training needs the ``rl`` extra (``pip install torch==2.13.0``
on a CPU machine), running a trained policy needs numpy only
(:class:`~mjchar.controllers.learned.mlp.MLP`). The network is the MLP of that module: inputs
normalised by the data's mean and standard deviation, ELU hidden layers, a linear output; the
loss is the mean squared error in the env's scaled action space.
"""

from __future__ import annotations

import numpy as np

from mjchar.bvh.errors import MjcharError
from mjchar.controllers.learned.mlp import MLP

__all__ = ["LearnError", "Trainer", "import_torch", "STD_FLOOR"]

#: the smallest input standard deviation normalised by (features that barely vary, such as a
#: clipped bound, are not blown up)
STD_FLOOR = 1e-2


class LearnError(MjcharError):
    """Learning cannot run (a missing extra, a bad option, an output that cannot be written)."""


def import_torch():
    """``torch``, or a one-line :class:`LearnError` saying how to install it."""
    try:
        import torch
    except ImportError:
        raise LearnError("training needs PyTorch (the rl extra): pip install torch==2.13.0 "
                         "(a CPU build; plain 'torch' pulls a CUDA build of several GB)"
                         ) from None
    return torch


class Trainer:
    """An MLP trained by Adam on ``(observation, action)`` pairs, kept between DAgger
    iterations (each iteration continues from the last weights on the grown data set).

    Args:
        n_in, n_out: sizes; hidden: hidden layer widths.
        lr: Adam's learning rate; batch: minibatch size; seed: initial weights and batches.
        threads: torch's intra-op threads.
    """

    def __init__(self, n_in: int, n_out: int, hidden=(512, 512), *, lr: float = 1e-3,
                 batch: int = 256, seed: int = 0, threads: int = 1):
        torch = self.torch = import_torch()
        torch.set_num_threads(max(1, int(threads)))
        torch.manual_seed(seed)
        layers, n = [], n_in
        for h in hidden:
            layers += [torch.nn.Linear(n, h), torch.nn.ELU()]
            n = h
        layers.append(torch.nn.Linear(n, n_out))
        self.net = torch.nn.Sequential(*layers).double()
        self.opt = torch.optim.Adam(self.net.parameters(), lr=lr)
        self.batch = int(batch)
        self.rng = np.random.default_rng(seed)
        self.mean = np.zeros(n_in)
        self.std = np.ones(n_in)
        self.hidden = tuple(int(h) for h in hidden)

    def fit(self, X: np.ndarray, Y: np.ndarray, epochs: float = 20.0,
            max_steps: int = 4000) -> tuple[float, float]:
        """Train on all of ``X (n, n_in)``, ``Y (n, n_out)`` for ``epochs`` passes (at most
        ``max_steps`` minibatches); the input normalisation is refitted to ``X`` first.
        Returns ``(loss before, loss after)``: the mean squared error over the data set."""
        torch = self.torch
        X = np.asarray(X, dtype=np.float64)
        Y = np.asarray(Y, dtype=np.float64)
        self.mean = X.mean(axis=0)
        self.std = np.maximum(X.std(axis=0), STD_FLOOR)
        Xn = torch.from_numpy((X - self.mean) / self.std)
        Yt = torch.from_numpy(Y)
        before = self.loss(Xn, Yt)
        n = len(X)
        steps = int(min(max_steps, max(1, np.ceil(epochs * n / self.batch))))
        self.net.train()
        for _ in range(steps):
            idx = torch.from_numpy(self.rng.integers(0, n, min(self.batch, n)))
            loss = torch.mean((self.net(Xn[idx]) - Yt[idx]) ** 2)
            self.opt.zero_grad()
            loss.backward()
            self.opt.step()
        return before, self.loss(Xn, Yt)

    def loss(self, Xn, Yt) -> float:
        """Mean squared error of the network on normalised inputs ``Xn`` against ``Yt``."""
        with self.torch.no_grad():
            return float(self.torch.mean((self.net(Xn) - Yt) ** 2))

    def mlp(self) -> MLP:
        """The network as a numpy :class:`MLP` (the same outputs)."""
        lin = [m for m in self.net if isinstance(m, self.torch.nn.Linear)]
        return MLP([m.weight.detach().numpy().copy() for m in lin],
                   [m.bias.detach().numpy().copy() for m in lin], self.mean.copy(),
                   self.std.copy())

    def state(self) -> dict:
        """What resuming needs: weights, optimiser state, normalisation."""
        return {"net": self.net.state_dict(), "opt": self.opt.state_dict(),
                "mean": self.mean, "std": self.std}

    def load_state(self, state: dict) -> None:
        self.net.load_state_dict(state["net"])
        self.opt.load_state_dict(state["opt"])
        self.mean, self.std = np.asarray(state["mean"]), np.asarray(state["std"])
