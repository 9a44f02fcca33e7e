"""Gait analysis of any walk in a converted model (a simulated run or a clip):
:mod:`~mjchar.bvh.gait.analysis` (steps, cadence, width, lean, knee flexion, stance slip)."""

from mjchar.bvh.gait.analysis import GaitAnalysisError, GaitStats, analyse, analyse_clip, table

__all__ = ["GaitAnalysisError", "GaitStats", "analyse", "analyse_clip", "table"]
