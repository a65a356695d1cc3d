"""How a predicted path is scored: displacement errors and their road-frame parts (DESIGN §17).

The average and final displacement errors (ADE, FDE) over the predicted samples, and their
lateral (|Δy|) and longitudinal (|Δx|) parts in the road frame (:data:`ERROR_METRICS`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["ERROR_METRICS", "displacement_errors", "error_parts"]

ERROR_METRICS = ("ade", "ade_lat", "ade_lon", "fde", "fde_lat", "fde_lon")
"""The errors of a prediction, as :func:`error_parts` names them."""


def displacement_errors(predicted: np.ndarray, actual: np.ndarray) -> tuple[float, float]:
    """(ADE, FDE): mean and final Euclidean distance over the predicted samples [m].

    Args:
        predicted: positions at j = 0 … H, shape (H + 1, 2) (row 0, the present, is
            not scored).
        actual: the true positions, same shape.

    Returns:
        (average displacement error, final displacement error).
    """
    d = np.hypot(*(predicted[1:, :2] - actual[1:, :2]).T)
    return float(d.mean()), float(d[-1])


def error_parts(predicted: np.ndarray, actual: np.ndarray) -> dict[str, float]:
    """ADE and FDE and their lateral and longitudinal parts [m].

    In the road frame: ADE = mean_j ‖p̂_j − p_j‖, ADE_lat = mean_j |ŷ_j − y_j|,
    ADE_lon = mean_j |x̂_j − x_j| over j = 1 … H; FDE, FDE_lat, FDE_lon the same at j = H.

    Args:
        predicted: positions at j = 0 … H, shape (H + 1, 2) (row 0 not scored).
        actual: the true positions, same shape.

    Returns:
        ``ade``, ``ade_lat``, ``ade_lon``, ``fde``, ``fde_lat``, ``fde_lon``.
    """
    ade, fde = displacement_errors(predicted, actual)
    d = np.abs(predicted[1:, :2] - actual[1:, :2])
    return {
        "ade": ade,
        "ade_lat": float(d[:, 1].mean()),
        "ade_lon": float(d[:, 0].mean()),
        "fde": fde,
        "fde_lat": float(d[-1, 1]),
        "fde_lon": float(d[-1, 0]),
    }
