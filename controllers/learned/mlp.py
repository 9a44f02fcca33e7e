"""Numpy inference of a multilayer perceptron: what running a learned policy needs (no deep-
learning framework).

The network maps a normalised observation to an action::

    h_0 = (x - mean) / std
    h_{i+1} = act(W_i h_i + b_i)        (hidden layers, act = ELU)
    y = W_L h_L + b_L                   (linear output)

with ``W_i`` of shape ``(out, in)`` (PyTorch's ``nn.Linear`` layout, so trained weights are
copied as they are). ELU (Clevert et al. 2016) is ``x`` for ``x > 0`` and ``exp(x) - 1``
otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["MLP", "elu"]


def elu(x: np.ndarray) -> np.ndarray:
    """ELU, elementwise: ``x`` where ``x > 0``, ``exp(x) - 1`` elsewhere."""
    return np.where(x > 0, x, np.expm1(np.minimum(x, 0.0)))


@dataclass
class MLP:
    """An MLP with input normalisation (see the module docstring).

    Attributes:
        weights: ``[(out, in) arrays]`` per layer, the last one linear.
        biases: ``[(out,) arrays]`` per layer.
        mean, std: ``(n_in,)`` the input normalisation (``std`` > 0).
    """

    weights: list
    biases: list
    mean: np.ndarray
    std: np.ndarray

    def __post_init__(self) -> None:
        self.weights = [np.asarray(w, dtype=np.float64) for w in self.weights]
        self.biases = [np.asarray(b, dtype=np.float64) for b in self.biases]
        self.mean = np.asarray(self.mean, dtype=np.float64)
        self.std = np.asarray(self.std, dtype=np.float64)
        if not self.weights or len(self.weights) != len(self.biases):
            raise ValueError("an MLP needs as many bias vectors as weight matrices (>= 1)")
        n = self.mean.shape[0]
        for w, b in zip(self.weights, self.biases, strict=True):
            if w.ndim != 2 or w.shape[1] != n or b.shape != (w.shape[0],):
                raise ValueError(f"layer shapes do not chain: weight {w.shape}, bias {b.shape}, "
                                 f"input {n}")
            n = w.shape[0]
        if self.std.shape != self.mean.shape or not np.all(self.std > 0):
            raise ValueError("the input std must have the input's shape and be positive")

    @property
    def n_in(self) -> int:
        """Input size."""
        return int(self.mean.shape[0])

    @property
    def n_out(self) -> int:
        """Output size."""
        return int(self.weights[-1].shape[0])

    @property
    def hidden(self) -> tuple[int, ...]:
        """Hidden layer widths."""
        return tuple(int(w.shape[0]) for w in self.weights[:-1])

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """``(..., n_out)`` outputs of inputs ``x (..., n_in)``."""
        h = (np.asarray(x, dtype=np.float64) - self.mean) / self.std
        last = len(self.weights) - 1
        for i, (w, b) in enumerate(zip(self.weights, self.biases, strict=True)):
            h = h @ w.T + b
            if i < last:
                h = elu(h)
        return h
