"""Online identification: a vehicle's risk posterior, current as its samples arrive (DESIGN §17).

:class:`StyleTracker` is the streaming form of
:func:`~drivestyle.irl.identification.posterior.identify_driver`. Each :meth:`StyleTracker.update`
with the vehicle's state ξ_k (and its neighbours') does two things:

1. it closes step k−1: the input u_{k−1} that carried ξ_{k−1} to ξ_k (given, or recovered
   by :func:`~drivestyle.envs.dynamics.inverse_step`) is compared with the plans the style
   made from ξ_{k−1} at every risk, and the residuals r = (u_0(ξ_{k−1}; p) − u_{k−1}) / σ_u
   are added to the running residual sums S(p);
2. it plans from ξ_k at the largest risk and — only if a chance constraint binds there
   (else every risk has the same optimum, :func:`~drivestyle.irl.driver.risk_profile.risk_profile`)
   — at the other risks of :data:`~drivestyle.irl.driver.risk_profile.RISK_EVAL`, each
   warm-started from its own previous plan as the offline pass is.

So an update costs one plan, or one batch of 13 when the vehicle is near another, and the
posterior after sample k equals the offline identification of the first k + 1 samples
(tested to round-off): same residuals, same warm starts, same likelihood
(:func:`~drivestyle.irl.identification.posterior.driver_posterior`).

A sample no vehicle can produce — a speed beyond v_max, a position jump, an implied
acceleration beyond any car's, a vehicle on top of the tracked one — is refused before it
touches anything (:func:`~drivestyle.envs.plausibility.step_problems` on it and the two
samples before it, the offline check): its residual would otherwise dwarf every other and,
through the residual scale s² it sets, flatten the posterior the earlier samples built. A
refused update, and one whose planning fails, leaves the tracker as it was.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from drivestyle.envs.demonstration import Demonstration
from drivestyle.envs.dynamics import inverse_step
from drivestyle.envs.plausibility import step_problems
from drivestyle.envs.safety import elliptical_index
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.driver.driver_style import INPUT_SCALE, RISK_RANGE, DriverStyle
from drivestyle.irl.driver.risk_profile import RISK_EVAL, RiskProfile
from drivestyle.irl.driver.style_planner import Link, PlanRow, StylePlanner, planner_for
from drivestyle.irl.identification.library import DriverLibrary
from drivestyle.irl.identification.posterior import driver_posterior
from drivestyle.irl.identification.result import Identification
from drivestyle.planning.description import PrimalDual

__all__ = [
    "StyleTracker",
    "TrackerError",
    "applied_input",
    "check_sample",
    "check_step",
    "track_demo",
]


class TrackerError(ValueError):
    """A sample the tracker cannot use (shape, finiteness, vehicle count, physics)."""


def _vector(value: object, shape: tuple[int, ...], what: str) -> np.ndarray:
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise TrackerError(f"{what} must be numeric, got {value!r}") from None
    if a.shape != shape:
        raise TrackerError(f"{what} must have shape {shape}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise TrackerError(f"{what} must be finite, got {a.tolist()}")
    return a


def check_sample(
    ev: object, others: object, m: int | None = None, u_prev: object = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """A tracker's sample as arrays, its form checked (every tracker's one check).

    Args:
        ev: the vehicle's state [x, y, φ, v], shape (4,).
        others: the surrounding vehicles' states, shape (m, 4), m >= 1.
        m: the number of surrounding vehicles of the earlier samples (None: the first).
        u_prev: the input [a, δ] since the previous sample, shape (2,), or None.

    Returns:
        (ev (4,), others (m, 4), u_prev (2,) or None) as float arrays.

    Raises:
        TrackerError: a wrong shape, a value not finite, another m than before.
    """
    xi = _vector(ev, (4,), "ev")
    rest = np.asarray(others, dtype=float)
    if rest.ndim != 2 or rest.shape[1] != 4 or rest.shape[0] < 1:
        raise TrackerError(f"others must have shape (m, 4) with m >= 1, got {rest.shape}")
    if not np.all(np.isfinite(rest)):
        raise TrackerError("others must be finite")
    if m is not None and rest.shape[0] != m:
        raise TrackerError(f"got {rest.shape[0]} surrounding vehicles, earlier samples had {m}")
    return xi, rest, None if u_prev is None else _vector(u_prev, (2,), "u_prev")


def check_step(
    recent: Sequence[np.ndarray], sample: np.ndarray, index: int, scenario: ScenarioConfig
) -> None:
    """Refuse a sample no vehicle can produce after the accepted ones (module docstring).

    Args:
        recent: the last (at most two) accepted samples, each [EV, others…] (1 + m, 4).
        sample: the new one, (1 + m, 4).
        index: the new sample's index (samples accepted before it).
        scenario: the vehicle's scenario (T_s, v_max, geometry).

    Raises:
        TrackerError: the sample breaks :func:`~drivestyle.envs.plausibility.step_problems`
            with the ones before it (the message names the sample and the value).
    """
    window = np.stack([*recent, sample])  # (k ≤ 3, 1 + m, 4), the new sample last
    k = window.shape[0]
    first = index + 1 - k
    t = (first + np.arange(k)) * scenario.dt
    problems = step_problems(t, window[:, 0], window[:, 1:], scenario, first)
    if problems:
        raise TrackerError(f"sample {index} refused: {problems[0]}")


def applied_input(
    previous: np.ndarray, xi: np.ndarray, scenario: ScenarioConfig, u: np.ndarray | None = None
) -> np.ndarray:
    """The input [a, δ] that carried the vehicle from ``previous`` to ``xi``.

    ``u`` where it is known (a simulation), else recovered from the two states by
    :func:`~drivestyle.envs.dynamics.inverse_step` within the scenario's input bounds.
    """
    if u is not None:
        return u
    sc = scenario
    lo, hi = (sc.a_min, -sc.delta_max), (sc.a_max, sc.delta_max)
    return inverse_step(previous, xi, sc.dt, sc.l_f, sc.l_r, lo, hi)


class StyleTracker:
    """The risk posterior of one vehicle, updated sample by sample (module docstring).

    Args:
        library: the driver library (the style's weights, its risks, τ).
        scenario: the vehicle's scenario (T_s, geometry, target lane, v_ref, bounds).
        risks: the risks the residual sums are kept at (increasing, in
            :data:`~drivestyle.irl.driver.driver_style.RISK_RANGE`).

    Raises:
        TrackerError: fewer than two risks, or risks outside the model's range.
    """

    def __init__(
        self,
        library: DriverLibrary,
        scenario: ScenarioConfig,
        risks: Sequence[float] = RISK_EVAL,
    ) -> None:
        self.library = library
        self.scenario = scenario
        self.risks = tuple(sorted(float(p) for p in risks))
        lo, hi = RISK_RANGE
        if len(self.risks) < 2 or not all(lo <= p <= hi for p in self.risks):
            raise TrackerError(f"need at least two risks in [{lo}, {hi}], got {risks!r}")
        self._styles = [replace(library.style, risk=p) for p in self.risks]
        self._scale = np.asarray(INPUT_SCALE)
        self.reset()

    def reset(self) -> None:
        """Forget every sample (a new vehicle in the same scenario)."""
        self._m: int | None = None
        self._planner: StylePlanner | None = None
        self._xi: np.ndarray | None = None
        self._ssr = np.zeros(len(self.risks))
        self._n_residuals = 0
        self._n_active = 0
        self._min_s_e = float("inf")
        # the plans from the last sample: first inputs per risk, activity, warm starts
        self._u0: np.ndarray | None = None
        self._active = False
        self._top: PrimalDual | None = None
        self._points: list[PrimalDual | None] = [None] * len(self.risks)
        self._estimate: Identification | None = None
        # the last two accepted samples [EV, others…] (the step checks' window)
        self._recent: list[np.ndarray] = []
        self.n_samples = 0
        """Samples accepted."""

    # ------------------------------------------------------------------ API
    def update(
        self, ev: np.ndarray, others: np.ndarray, u_prev: np.ndarray | None = None
    ) -> Identification:
        """Add the vehicle's next sample; return the posterior over its risk.

        Args:
            ev: the vehicle's state [x, y, φ, v], shape (4,), T_s after the previous one.
            others: the surrounding vehicles' states, shape (m, 4) (the same m every
                sample; the vehicle it reacts to first).
            u_prev: the input [a, δ] applied since the previous sample, if known
                (simulation); None recovers it from the two states.

        Returns:
            The :class:`~drivestyle.irl.identification.result.Identification` of the samples so
            far (the uniform prior, verdict ``no_constraint``, until a step where p matters).

        Raises:
            TrackerError: a sample of the wrong shape, not finite, with another number of
                surrounding vehicles than before, or that no vehicle can produce (a speed
                beyond v_max, a jump, an acceleration beyond any car's, an overlap with a
                surrounding vehicle; the message names the sample and the value). The
                tracker is then as before the call.
        """
        xi, others, u = check_sample(ev, others, self._m, u_prev)
        sample = np.vstack([xi, others])
        check_step(self._recent, sample, self.n_samples, self.scenario)
        # everything below mutates: on any failure (a solver's, say) restore the state, so
        # that a refused sample leaves the evidence of the earlier ones as it was
        saved = {**self.__dict__, "_ssr": self._ssr.copy(), "_recent": list(self._recent)}
        try:
            return self._accept(xi, others, u, sample)
        except BaseException:
            self.__dict__.update(saved)
            raise

    def _accept(
        self, xi: np.ndarray, others: np.ndarray, u: np.ndarray | None, sample: np.ndarray
    ) -> Identification:
        """Add a checked sample: close the step before it, plan from it, the posterior."""
        if self._m is None:
            self._m = others.shape[0]
            n_vehicles = 1 if self._m == 1 else 4  # as the offline pass (_n_vehicles)
            self._planner = planner_for(self.scenario, self.library.style.horizon, n_vehicles)
        if self._xi is not None:
            self._close_step(xi, u)
        sc = self.scenario
        s_e = elliptical_index(xi[0] - others[:, 0], xi[1] - others[:, 1], sc.l_a, sc.l_b)
        self._min_s_e = min(self._min_s_e, float(np.min(s_e)))
        self._plan(xi, others)
        self._xi = xi
        self._recent = [*self._recent[-1:], sample]
        self.n_samples += 1
        self._estimate = driver_posterior([self.profile], self.library, [self._min_s_e], [None])
        return self._estimate

    @property
    def profile(self) -> RiskProfile:
        """The residual sums of the closed steps as a :class:`RiskProfile`."""
        return RiskProfile(self.risks, tuple(self._ssr.tolist()), self._n_residuals,
                           self._n_active)  # fmt: skip

    @property
    def estimate(self) -> Identification | None:
        """The latest posterior (None before the first sample)."""
        return self._estimate

    def style(self, risk: str = "mean") -> DriverStyle:
        """The library's style at the posterior ``"mean"`` or ``"mode"`` (density's argmax).

        Before the first sample: the prior's mean, the middle of the risk range.

        Raises:
            TrackerError: ``risk`` is neither.
        """
        est = self._estimate
        if risk not in ("mean", "mode"):
            raise TrackerError(f"risk must be 'mean' or 'mode', got {risk!r}")
        if est is None:
            p = sum(RISK_RANGE) / 2
        elif risk == "mean":
            p = est.risk_interpolated
        else:
            p = est.density_risks[int(np.argmax(est.density))]
        lo, hi = RISK_RANGE
        return replace(self.library.style, risk=float(min(max(p, lo), hi)))

    # ------------------------------------------------------------------ steps
    def _close_step(self, xi: np.ndarray, u: np.ndarray | None) -> None:
        """Residuals of the plans from the previous sample against the input applied."""
        assert self._xi is not None and self._u0 is not None
        u = applied_input(self._xi, xi, self.scenario, u)
        r2 = np.sum(((self._u0 - u) / self._scale) ** 2, axis=1)
        self._ssr = self._ssr + (r2 if self._active else r2[-1])  # a new array: see update
        self._n_residuals += 2
        self._n_active += int(self._active)

    def _plan(self, xi: np.ndarray, others: np.ndarray) -> None:
        """The plans from ξ_k: the largest risk, then the others where a constraint binds."""
        planner, sc = self._planner, self.scenario
        assert planner is not None
        top = planner.solve_rows(
            [PlanRow(xi, others, self._styles[-1], Link(given=planner.guess(xi, self._top)))], sc
        )
        n = len(self.risks)
        u0 = np.repeat(top.u0, n, axis=0)
        active = bool(top.chance_active[0])
        if active:
            # each risk from its own previous plan where the previous step was re-solved,
            # else from the largest risk's (the offline pass's warm starts)
            rows = [
                PlanRow(xi, others, self._styles[j], Link(given=planner.guess(
                    xi, self._points[j] if self._active else self._top)))
                for j in range(n - 1)
            ]  # fmt: skip
            out = planner.solve_rows(rows, sc)
            u0[:-1] = out.u0
            self._points = [out.points(j) for j in range(n - 1)] + [None]
        self._top = top.points(0)
        self._u0, self._active = u0, active


def track_demo(
    library: DriverLibrary, demo: Demonstration, use_inputs: bool = True
) -> list[Identification]:
    """Feed a demonstration to a fresh :class:`StyleTracker` sample by sample.

    Args:
        library: the driver library.
        demo: the vehicle's demonstration (on its scenario's T_s grid).
        use_inputs: pass the recorded inputs (else the tracker recovers them).

    Returns:
        The posterior after each sample, length n.
    """
    tracker = StyleTracker(library, demo.scenario)
    vehicles = demo.vehicles
    out = []
    for k in range(demo.n):
        u = demo.u[k - 1] if (use_inputs and k > 0) else None
        out.append(tracker.update(demo.ev[k], vehicles[k], u))
    return out
