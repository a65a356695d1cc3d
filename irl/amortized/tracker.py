"""Online amortized identification: the posterior over a driver's parameters as samples arrive.

:class:`AmortizedTracker` is the streaming form of
:func:`~drivestyle.irl.amortized.identify.identify_amortized`, beside the exact risk
posterior's :class:`~drivestyle.irl.identification.online.StyleTracker` (DESIGN §17, §22).
Each :meth:`AmortizedTracker.update` with the vehicle's state ξ_k (and its neighbours')

1. checks the sample as the exact tracker does
   (:func:`~drivestyle.irl.identification.online.check_sample`,
   :func:`~drivestyle.irl.identification.online.check_step`: a sample no vehicle can
   produce is refused and leaves the tracker as it was) and keeps the input that carried
   ξ_{k−1} to ξ_k (given, or recovered:
   :func:`~drivestyle.irl.identification.online.applied_input`);
2. computes the encoder's input rows of the new sample by the offline rule itself —
   :func:`~drivestyle.irl.amortized.identify.observed_series` of the samples so far, whose
   rows 0 … k−1 do not change when sample k arrives (it reads nothing after its last
   sample; the tracker checks the row it fed last) — so the per-sample features have one
   home, whatever channels they gain;
3. advances the encoder by one GRU step from its hidden state and the running sum of its
   outputs (the encoder's ``step``), so that after k + 1 samples its summary equals the
   encoder's ``forward`` over the samples 0 … k (tested to 1e-5).

:meth:`AmortizedTracker.summary` draws ``draws`` posterior samples from the current summary
(one flow sampling call, seeded by ``seed`` each time: the same base noise every call, so
consecutive summaries differ by what the samples changed, not by Monte-Carlo noise) and
returns an :class:`~drivestyle.irl.amortized.identify.AmortizedStyle`. An update costs one
GRU step and the numpy features of the prefix; a summary costs the flow's sampling, whose
autoregressive inversion makes D sequential passes per transform (RESULTS §19).
Torch is imported when a tracker is made.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from drivestyle.envs.demonstration import Demonstration, Origin
from drivestyle.envs.scenario import ScenarioConfig
from drivestyle.irl.amortized.estimator import NeuralPosterior
from drivestyle.irl.amortized.identify import AmortizedStyle, observed_series, summarise_draws
from drivestyle.irl.identification.online import (
    TrackerError,
    applied_input,
    check_sample,
    check_step,
)
from drivestyle.recorded.observed import observed_mask

if TYPE_CHECKING:
    import torch

__all__ = ["DRAWS", "AmortizedTracker", "track_amortized"]

DRAWS = 32
"""Posterior draws of a tracker's summary (few: it is asked for often)."""


class AmortizedTracker:
    """The amortized posterior of one vehicle, updated sample by sample (module docstring).

    Args:
        posterior: the estimator.
        scenario: the vehicle's scenario (T_s, the bounds the inputs are recovered within
            and the samples checked against).
        draws: posterior draws per :meth:`summary` (>= 2).
        seed: seeds every summary's draws.
        origin: ``"recorded"`` for a recorded vehicle (seen through the recorded view as
            offline), else ``"simulated"``.

    Raises:
        TrackerError: ``draws`` < 2.
    """

    def __init__(
        self,
        posterior: NeuralPosterior,
        scenario: ScenarioConfig,
        draws: int = DRAWS,
        seed: int = 0,
        origin: Origin = "simulated",
    ) -> None:
        import torch

        if draws < 2:
            raise TrackerError(f"draws must be >= 2, got {draws}")
        self.posterior = posterior
        self.scenario = scenario
        self.draws = int(draws)
        self.seed = int(seed)
        self.origin: Origin = origin
        self._encoder: Any = posterior.network["encoder"]
        self._digest = posterior.weights_sha256()
        self._meta = {"scenario": scenario.to_dict()}
        self._torch = torch
        self.reset()

    def reset(self) -> None:
        """Forget every sample (a new vehicle in the same scenario)."""
        self._m: int | None = None
        self._samples: list[np.ndarray] = []  # [EV, others…] (1 + m, 4) per sample
        self._seen: list[np.ndarray] = []  # per sample, (m,) bool: which vehicles are observed
        self._inputs: list[np.ndarray] = []  # u_0 … u_{k−1}
        self._state: tuple[torch.Tensor, torch.Tensor, int] = self._encoder.start(1)
        self._summary_vector: torch.Tensor | None = None
        self._last_row: np.ndarray | None = None
        self.n_samples = 0
        """Samples accepted."""

    def update(
        self,
        ev: np.ndarray,
        others: np.ndarray,
        u_prev: np.ndarray | None = None,
        observed: np.ndarray | None = None,
    ) -> None:
        """Add the vehicle's next sample (one GRU step; :meth:`summary` gives the posterior).

        Args:
            ev: the vehicle's state [x, y, φ, v], shape (4,), T_s after the previous one.
            others: the surrounding vehicles' states, shape (m, 4), the same m every sample
                (the TV first, as a demonstration orders them).
            u_prev: the input [a, δ] applied since the previous sample, if known; None
                recovers it from the two states.
            observed: per surrounding vehicle whether its state is observed at this
                sample, shape (m,) bool (None: all are).

        Raises:
            TrackerError: a sample of the wrong form, or one no vehicle can produce after
                the accepted ones (:func:`~drivestyle.irl.identification.online.check_step`);
                the tracker is then as before the call.
        """
        xi, rest, u = check_sample(ev, others, self._m, u_prev)
        seen = np.ones(rest.shape[0], bool) if observed is None else np.asarray(observed, bool)
        if seen.shape != (rest.shape[0],):
            raise TrackerError(f"observed must have shape ({rest.shape[0]},), got {seen.shape}")
        sample = np.vstack([xi, rest])
        check_step(self._samples[-2:], sample, self.n_samples, self.scenario)
        inputs = list(self._inputs)
        if self._samples:
            inputs.append(applied_input(self._samples[-1][0], xi, self.scenario, u))
        k = self.n_samples
        rows = observed_series(self._prefix([*self._samples, sample], [*self._seen, seen], inputs),
                               k)  # fmt: skip
        if self._last_row is not None and not np.allclose(rows[k - 1], self._last_row,
                                                          rtol=0, atol=1e-9):  # fmt: skip
            raise RuntimeError(
                f"the encoder's input of sample {k - 1} changed when sample {k} arrived: the "
                "episode's features read later samples, which no observer has"
            )
        torch = self._torch
        with torch.no_grad():
            x = torch.as_tensor(rows[k][None], dtype=torch.float32)
            summary, state = self._encoder.step(x, self._state)
        self._m = rest.shape[0]
        self._samples.append(sample)
        self._seen.append(seen)
        self._inputs = inputs
        self._state, self._summary_vector = state, summary
        self._last_row = rows[k].copy()
        self.n_samples += 1

    def _prefix(
        self, samples: list[np.ndarray], seen: list[np.ndarray], inputs: list[np.ndarray]
    ) -> Demonstration:
        """The samples so far as a demonstration.

        At least 3 samples: the last one repeated at later times, which
        :func:`observed_series` of the last real sample never reads.
        """
        n = len(samples)
        pad = max(3 - n, 0)
        states = np.stack(samples + [samples[-1]] * pad)  # (n', 1 + m, 4)
        mask = np.stack(seen + [seen[-1]] * pad, axis=1)  # (m, n')
        u = np.zeros((n + pad - 1, 2))
        if inputs:
            u[: len(inputs)] = inputs
        return Demonstration(
            t=np.arange(n + pad) * self.scenario.dt,
            ev=states[:, 0],
            tv=states[:, 1],
            u=u,
            meta=self._meta,
            others=states[:, 2:],
            origin=self.origin,
            observed=mask,
        )

    @property
    def embedding(self) -> np.ndarray | None:
        """The encoder's summary of the samples so far, shape (embedding,) (None: no sample)."""
        s = self._summary_vector
        return None if s is None else s[0].double().numpy()

    def summary(self) -> AmortizedStyle:
        """The posterior of the samples so far: ``draws`` draws seeded by ``seed``.

        Raises:
            TrackerError: no sample yet.
        """
        if self._summary_vector is None:
            raise TrackerError("no sample yet: update the tracker first")
        draws = self.posterior.sample_embedded(self._summary_vector, self.draws, self.seed)[0]
        return summarise_draws(draws, self.posterior.config.names, self.n_samples, self._digest)


def track_amortized(
    posterior: NeuralPosterior,
    demo: Demonstration,
    draws: int = DRAWS,
    seed: int = 0,
    use_inputs: bool = True,
) -> list[AmortizedStyle]:
    """Feed a demonstration to a fresh :class:`AmortizedTracker`; the summary after each sample.

    Args:
        posterior: the estimator.
        demo: the vehicle's demonstration (on its scenario's T_s grid).
        draws: posterior draws per summary.
        seed: their seed.
        use_inputs: pass the recorded inputs (else the tracker recovers them).

    Returns:
        The posterior after each sample, length n.
    """
    tracker = AmortizedTracker(posterior, demo.scenario, draws, seed, demo.origin)
    vehicles, seen = demo.vehicles, observed_mask(demo)
    out = []
    for k in range(demo.n):
        u = demo.u[k - 1] if (use_inputs and k > 0) else None
        tracker.update(demo.ev[k], vehicles[k], u, seen[:, k])
        out.append(tracker.summary())
    return out
