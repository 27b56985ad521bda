r"""Pitching and yawing of the slider with stick-slip (chapter 6 of the paper): the moments
of the drive force about the neutral points tilt the slider through a compliance, with a
squeeze-film lag (sections 6.2-6.4). `model` gives the coordinates, units and physics.
"""

from .cycle import ForceCycle, steady_force_cycle
from .design import DesignPoint, TiltMap, best_drive_point, variation_map
from .metrics import (CriticalSpeeds, PlaneSummary, SteadyTilt, critical_pitch_speed, cycle_tilt,
                      steady_tilt, tilt_against_speed, window_summary)
from .model import (ETA_A, PAPER_DRIVE_POINTS, PITCH, YAW, DrivePoint, LinearLag, MeasuringPoints,
                    PitchingModel, TiltPlane, default_model, first_order, paper_points)
from .response import (TiltTrace, filtered_force, lag_response, point_displacements, recovery_curve,
                       rise_curve, tilt_history)

__all__ = ["CriticalSpeeds", "DesignPoint", "TiltMap", "DrivePoint", "ETA_A", "ForceCycle",
           "LinearLag", "MeasuringPoints", "PAPER_DRIVE_POINTS", "PITCH", "PitchingModel",
           "PlaneSummary", "SteadyTilt", "TiltPlane", "TiltTrace", "YAW", "best_drive_point",
           "critical_pitch_speed", "cycle_tilt", "default_model", "filtered_force", "first_order",
           "lag_response", "paper_points", "point_displacements", "recovery_curve", "rise_curve",
           "steady_force_cycle", "steady_tilt", "tilt_against_speed", "tilt_history",
           "variation_map", "window_summary"]
