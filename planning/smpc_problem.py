"""The SMPC planner's NLP and its solvers (DESIGN §3).

:class:`SMPCProblem` holds the NLP of one configuration and scenario geometry (T_s, l_f,
l_r, l_a, l_b, :meth:`SMPCProblem.serves`; transcribed by
:func:`drivestyle.planning.transcription.transcribe`) and its CasADi solvers: fatrop
(interpreted, ``jit``-compiled or generated C cached on disk) and the IPOPT retry, all
reading and writing numpy buffers bound once. The bounds (road, speed, inputs) come per
scenario from :func:`~drivestyle.planning.description.nlp_bounds`. It holds nothing of a
closed loop: the previous plan and the fallbacks live in
:class:`drivestyle.agents.smpc.SMPCExpert` and the style model's planner, the warm start
in :mod:`drivestyle.planning.warm_starts`.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
from dataclasses import dataclass

import casadi as ca
import numpy as np

from drivestyle.envs.scenario import PAPER, ScenarioConfig
from drivestyle.planning.buffered import BufferedFunction
from drivestyle.planning.compiled import compiled_function, source_digest
from drivestyle.planning.description import (
    SOLVERS,
    NLPBounds,
    PrimalDual,
    SMPCConfig,
    nlp_bounds,
    nlp_layout,
)
from drivestyle.planning.transcription import geometry_key, transcribe

__all__ = [
    "NLPSolution",
    "SMPCProblem",
    "solver_options",
]


def solver_options(name: str, config: SMPCConfig, equality: np.ndarray) -> dict:
    """CasADi ``nlpsol`` options of solver ``name`` for this NLP.

    Args:
        name: 'fatrop' or 'ipopt'.
        config: iteration cap, tolerance, initial barrier parameter, jit.
        equality: per row of g, whether it is an equality (fatrop needs it).

    Returns:
        The options dict.
    """
    if name not in SOLVERS:
        raise ValueError(f"solver must be one of {SOLVERS}, got {name!r}")
    common: dict = {"expand": True, "print_time": False}
    if config.jit:
        # compile the NLP's derivative functions with the system C compiler
        common |= {
            "jit": True,
            "compiler": "shell",
            "jit_options": {"flags": ["-O2"], "verbose": False},
        }
    if name == "fatrop":
        return common | {
            "structure_detection": "auto",
            "equality": equality.tolist(),
            "fatrop": {
                "print_level": 0,
                "max_iter": config.max_iter,
                "tol": config.tol,
                "mu_init": config.mu_init,
            },
        }
    return common | {
        "ipopt": {
            "print_level": 0,
            "sb": "yes",
            "max_iter": config.max_iter,
            "tol": config.tol,
            "mu_init": config.mu_init,
            # the guess is the shifted previous solution: keep it (and its multipliers)
            "warm_start_init_point": "yes",
            "warm_start_bound_push": 1e-6,
            "warm_start_mult_bound_push": 1e-6,
        },
    }


@dataclass(frozen=True, eq=False)
class NLPSolution:
    """What one solver call returned (copies; the solver's buffers are reused)."""

    solver: str
    """The solver that ran."""
    success: bool
    """The solver reported success."""
    status: str
    """Solver return status (``'error: …'`` when CasADi raised)."""
    iterations: int
    """Solver iterations (−1 when CasADi raised)."""
    point: PrimalDual
    """The returned primal-dual point."""
    g: np.ndarray
    """Constraint values at ``point.w``."""


class SMPCProblem:
    """The SMPC NLP of one configuration and scenario geometry, and its solvers.

    Example:
        >>> problem = SMPCProblem(SMPCConfig(), PAPER)
        >>> p = nlp_parameters(xi0, tv[None], PAPER.y_ref, PAPER.v_ref, 0.52)
        >>> sol = problem.solve("fatrop", p, guess, problem.bounds(PAPER))

    Pure transcription: no state carries over from one solve to the next. The solver
    reads and writes numpy buffers in place (zero-copy calls save ≈0.2 ms of
    numpy↔DM conversion per solve); :meth:`solve` fills them from its arguments and
    returns copies.
    """

    def __init__(self, config: SMPCConfig | None = None, scenario: ScenarioConfig = PAPER):
        """Transcribe the NLP and build the primary solver ``config.solver``.

        Args:
            config: SMPC parameters (the risk is not used: κ is a parameter of each solve).
            scenario: the geometry the NLP is built for.
        """
        self.config = config or SMPCConfig()
        self.scenario = scenario
        self.layout = nlp_layout(self.config.horizon, self.config.max_vehicles)
        self.nlp, self.dynamics = transcribe(self.config, scenario)
        self._external: set[str] = set()
        self._kkt: BufferedFunction | None = None
        self._step = BufferedFunction(self.dynamics)
        primary = self._make_solver(self.config.solver)
        self._inputs = {n: np.zeros(primary.nnz_in(n)) for n in primary.name_in()}
        self._outputs = {n: np.zeros(primary.nnz_out(n)) for n in primary.name_out()}
        # further solvers (the retry) are built on first use and share the buffers
        self._calls: dict[str, tuple] = {self.config.solver: self._bind(primary)}

    @property
    def n_p(self) -> int:
        """Number of parameters, 4 + 4M + 3 (+ 5 weights if parametric)."""
        return int(self.nlp["p"].numel())

    def serves(self, scenario: ScenarioConfig) -> bool:
        """Whether this NLP is the one of ``scenario`` (same T_s, l_f, l_r and ellipse)."""
        given = self.config.weights_as_parameters
        return geometry_key(scenario, given) == geometry_key(self.scenario, given)

    def bounds(self, scenario: ScenarioConfig) -> NLPBounds:
        """:func:`~drivestyle.planning.description.nlp_bounds` of ``scenario`` for this layout."""
        return nlp_bounds(self.layout, scenario)

    def solve(
        self, solver: str, p: np.ndarray, guess: PrimalDual, bounds: NLPBounds
    ) -> NLPSolution:
        """Solve the NLP once with ``solver`` from ``guess``.

        Args:
            solver: 'fatrop' or 'ipopt' (built on first use).
            p: parameters (:func:`~drivestyle.planning.description.nlp_parameters`).
            guess: initial primal-dual point.
            bounds: variable and constraint bounds.

        Returns:
            The solver's point and status; a CasADi error (NaN evaluation, solver
            exception) is a failed solution, not an exception.

        Raises:
            ValueError: ``p`` or the guess has a NaN or inf entry (fatrop does not return
                from a NaN initial guess).
        """
        for name, value in (("p", p), ("guess.w", guess.w), ("guess.lam_g", guess.lam_g),
                            ("guess.lam_x", guess.lam_x)):  # fmt: skip
            if not np.all(np.isfinite(value)):
                raise ValueError(f"SMPC problem input {name} contains NaN or inf")
        buffer, evaluate = self._solver_call(solver)
        for name, value in (
            ("p", p), ("x0", guess.w), ("lam_g0", guess.lam_g), ("lam_x0", guess.lam_x),
            ("lbx", bounds.lbw), ("ubx", bounds.ubw), ("lbg", bounds.lbg), ("ubg", bounds.ubg),
        ):  # fmt: skip
            self._inputs[name][:] = value
        try:
            evaluate()
            if solver in self._external:  # the generated solver has no stats
                out = self._outputs
                success = self._stationary(out["x"], out["lam_g"], out["lam_x"])
                status = "Solve_Succeeded" if success else "not stationary"
                iterations = -1
            else:
                stats = buffer.stats()
                success = bool(stats.get("success", False))
                status = str(stats.get("return_status", "unknown"))
                iterations = int(stats.get("iter_count", -1))
        except RuntimeError as exc:  # CasADi raises on NaN evaluations, solver errors, ...
            success, status, iterations = False, f"error: {exc}".splitlines()[0], -1
        out = self._outputs
        point = PrimalDual(out["x"].copy(), out["lam_g"].copy(), out["lam_x"].copy())
        return NLPSolution(solver, success, status, iterations, point, out["g"].copy())

    def step(self, xi: np.ndarray, u: np.ndarray) -> np.ndarray:
        """F(ξ, u), one RK4 step, through bound buffers.

        :attr:`dynamics`' result to the bit, without its numpy↔DM conversions (≈ 60 µs of
        every warm start's shift).
        """
        return self._step(xi, u)[0]

    def _stationary(self, w: np.ndarray, lam_g: np.ndarray, lam_x: np.ndarray) -> bool:
        """Whether a generated solver's point is a KKT point to fatrop's tolerance.

        ‖∇f + J_gᵀλ_g + λ_x‖∞ ≤ 10·tol·s_d, with IPOPT's scaling s_d = max(1, mean |λ| / 100)
        (the slack penalty puts multipliers at ≈ 1e4); feasibility is the caller's check.
        """
        if self._kkt is None:
            x, p = self.nlp["x"], self.nlp["p"]
            lg, lx = ca.SX.sym("lg", self.layout.n_g), ca.SX.sym("lx", self.layout.n_w)
            lagrangian = self.nlp["f"] + ca.dot(lg, self.nlp["g"]) + ca.dot(lx, x)
            # bound buffers: a plain call converted four inputs and the result to DM on
            # every solve, ≈ a fifth of a tracker update's solve time
            self._kkt = BufferedFunction(
                ca.Function("kkt", [x, p, lg, lx], [ca.gradient(lagrangian, x)])
            )
        (grad,) = self._kkt.evaluate(w, self._inputs["p"], lam_g, lam_x)
        scale = max(1.0, float(np.mean(np.abs(np.concatenate([lam_g, lam_x])))) / 100.0)
        return bool(
            np.all(np.isfinite(grad)) and np.max(np.abs(grad)) <= 10 * self.config.tol * scale
        )

    def _make_solver(self, name: str) -> ca.Function:
        options = solver_options(name, self.config, self.layout.equality)
        if self.config.compiled and name == "fatrop":
            plain = {
                k: v for k, v in options.items() if k not in ("jit", "compiler", "jit_options")
            }
            # the generated solver has no stats(): a failure must raise instead
            compiled = compiled_function(
                "ds_smpc_fatrop",
                _compiled_key(self.config, self.scenario),
                lambda: ca.nlpsol("ds_smpc_fatrop", "fatrop", self.nlp, plain),
                link_casadi=True,
            )
            if compiled is not None:
                self._external.add(name)
                return compiled
        if not self.config.jit:
            return ca.nlpsol(f"smpc_{name}", name, self.nlp, options)
        # CasADi writes the generated C (and leaves it) in the working directory: build in
        # a folder of its own under the temp folder, never in the user's cwd
        cwd = os.getcwd()
        os.chdir(tempfile.mkdtemp(prefix="drivestyle_jit_"))
        try:
            return ca.nlpsol(f"smpc_{name}", name, self.nlp, options)
        finally:
            os.chdir(cwd)

    def _solver_call(self, name: str) -> tuple:
        if name not in self._calls:
            self._calls[name] = self._bind(self._make_solver(name))
        return self._calls[name]

    def _bind(self, solver: ca.Function) -> tuple:
        """(buffer, evaluate) of ``solver`` reading and writing the shared numpy buffers."""
        buffer, evaluate = solver.buffer()
        # .data: the arrays' memoryviews (numpy's stubs give ndarray no __buffer__ before
        # Python 3.12). casadi's stub also lists the byte size, which its SWIG wrapper reads
        # from the buffer itself and refuses as a third argument.
        for i, n in enumerate(solver.name_in()):
            buffer.set_arg(i, self._inputs[n].data)  # type: ignore[call-arg]
        for i, n in enumerate(solver.name_out()):
            buffer.set_res(i, self._outputs[n].data)  # type: ignore[call-arg]
        return buffer, evaluate


def _compiled_key(config: SMPCConfig, scenario: ScenarioConfig) -> str:
    """Digest of everything the generated fatrop solver depends on."""
    c = config
    fields = (c.horizon, c.max_vehicles, c.weights_as_parameters, c.predicted_paths,
              c.Q, c.Q_N, c.R, c.uncertainty, c.max_iter, c.tol, c.mu_init, c.slack_l1,
              c.slack_l2,
              geometry_key(scenario, c.weights_as_parameters))  # fmt: skip
    digest = source_digest([
        "drivestyle.envs.dynamics", "drivestyle.planning.chance", "drivestyle.planning.compiled",
        "drivestyle.planning.tv_gaussian", "drivestyle.planning.description",
        "drivestyle.planning.transcription", "drivestyle.planning.smpc_problem",
    ])  # fmt: skip
    return hashlib.sha256((repr(fields) + digest).encode()).hexdigest()
