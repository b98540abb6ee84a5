"""``bo``: Bayesian optimization with scikit-optimize's Gaussian process, batched fast.

``skopt.Optimizer.ask(n_points=8)`` with its defaults refits the GP with a hyperparameter search
for every point of a batch (constant liar) and polishes ``gp_hedge`` over 10,000 candidates with
L-BFGS: 20 s to over 2 min per batch at 200 observations on a shared two-core machine. This
plugin keeps skopt's model (the ``cook_estimator("GP")`` Matern-5/2 GP with a fitted noise
level, normalized y) and its acquisition functions, and changes how a batch is made
(``perf/speed/optimizers_overhead.py`` measures the difference: 0.3 s warm and 1.8 s cold
at 200 observations against 141 s, with equal or better best values on a shifted sphere and on
Rosenbrock at 48 evaluations):

1. The GP hyperparameters are fitted once per batch by one L-BFGS run warm-started from the
   previous batch's values (the first fit, with nothing to start from, adds ``gp_restarts``
   random restarts).
2. The batch is filled by a Kriging believer loop: pick the acquisition's best point, add it with
   the GP mean as its value, refit with the hyperparameters held fixed (one Cholesky
   factorization), repeat. Points asked earlier and still pending are believers from the start.
3. The acquisition is maximized over ``n_points`` uniform candidates, then refined around the
   best one by two rounds of 100 candidates in boxes of +-5 % and +-0.5 % of the box
   (``acq_optimizer="sampling"``), or by skopt's L-BFGS-B polishing with its gradient
   (``"lbfgs"``, about twice the time per batch). The posterior over many candidates is
   computed with scikit-learn's triangular-solve prediction, which gives skopt's predictive
   mean and std without its (n_points x n^2) einsum.
4. BLAS runs single-threaded during a batch: on a shared two-core machine, threaded BLAS on
   200 x 200 matrices costs more in contention than it gains.

Failures are kept as such and re-penalized at every fit with the current penalty (the worst
finite value so far plus a margin), so an early failure's penalty tracks the values seen later.
All randomness (initial design, candidates, GP restarts) comes from the optimizer's generator.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, cast

import numpy as np

from ._imports import import_optional
from .base import Optimizer

__all__ = ["BayesianOptimization"]

ACQUISITION_FUNCTIONS = ("EI", "PI", "LCB")
ACQ_OPTIMIZERS = ("sampling", "lbfgs")
_ZOOM = (0.05, 0.005)  # half-widths of the local sampling rounds, in box widths
_N_ZOOM = 100  # candidates per local round


#: Largest settings: the initial Latin hypercube is optimized by pairwise distances (10,000
#: points: about 20 s and 400 MB; 10^9 allocated 7.45 GiB), candidates are predicted at once
#: against every observation (10^5 by 1,000: 800 MB), and each restart is a full L-BFGS fit.
N_INITIAL_POINTS_MAX = 10_000
N_POINTS_MAX = 100_000
GP_RESTARTS_MAX = 100


def _count(value: Any, name: str, low: int, high: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise TypeError(f"{name} must be an int from {low} to {high}, got {value!r}")
    if not low <= value <= high:
        raise ValueError(f"{name} must be an int from {low} to {high}, got {value}")
    return int(value)


class _Posterior:
    """A fitted skopt GP whose ``predict`` uses scikit-learn's O(n_points n^2) BLAS path.

    skopt's ``GaussianProcessRegressor.predict(return_std=True)`` computes the variance with
    ``einsum("ki,kj,ij->k")`` and an explicit inverse of K, which is slow for many candidates and
    loses digits when K is ill-conditioned; scikit-learn's parent method gives the same mean and
    std (the fitted noise is excluded in both) by a triangular solve.
    """

    def __init__(self, gp: Any) -> None:
        self.gp = gp

    def predict(self, X: np.ndarray, return_std: bool = False) -> Any:
        from sklearn.gaussian_process import GaussianProcessRegressor

        return GaussianProcessRegressor.predict(self.gp, X, return_std=return_std)


class BayesianOptimization(Optimizer):
    """GP-based Bayesian optimization (scikit-optimize) in the unit box, with fast batches.

    Not generational: it may be asked again while evaluations are pending, and pending points
    are treated as believers. The first ``n_initial_points`` points (pending ones counted) are
    a Latin hypercube from skopt's ``Lhs``; then each batch is made as the module docstring
    says.

    Args:
        bounds: (d, 2) [low, high] per dimension in physical units.
        n_initial_points: Points of the space-filling initial design, 1 to 10,000 (skopt's
            default 10).
        acq_func: ``"EI"`` (expected improvement), ``"PI"`` (probability of improvement) or
            ``"LCB"`` (lower confidence bound).
        xi: EI and PI: improvement margin, in units of the objective, >= 0. The default 0 is
            plain EI; skopt's 0.01 stops refining once values differ by less than 0.01 (on a
            shifted sphere it ends 40 times further from the minimum at 48 evaluations).
        kappa: LCB: weight of the predictive std, >= 0.
        n_points: Uniform candidates the acquisition is evaluated on per point, 1 to 100,000.
        acq_optimizer: ``"sampling"`` (refine the best candidate by local sampling rounds) or
            ``"lbfgs"`` (polish it with L-BFGS-B).
        gp_restarts: Random restarts of the first GP hyperparameter search, 0 to 100; later
            searches start from the previous batch's hyperparameters.
        **kwargs: ``batch_size``, ``seed``, ``failure_policy``, ``low``/``high`` of
            :class:`~optimizers.base.Optimizer`.

    Raises:
        DependencyNotInstalled: scikit-optimize is missing (``pip install tooldesign[bo]``).
        TypeError: A setting of the wrong type.
        ValueError: A setting outside its range.
    """

    def __init__(
        self,
        bounds: Any = None,
        *,
        n_initial_points: int = 10,
        acq_func: str = "EI",
        xi: float = 0.0,
        kappa: float = 1.96,
        n_points: int = 1000,
        acq_optimizer: str = "sampling",
        gp_restarts: int = 2,
        **kwargs: Any,
    ) -> None:
        super().__init__(bounds, **kwargs)
        self._n_initial = _count(n_initial_points, "n_initial_points", 1, N_INITIAL_POINTS_MAX)
        if acq_func not in ACQUISITION_FUNCTIONS:
            raise ValueError(f"acq_func must be one of {ACQUISITION_FUNCTIONS}, got {acq_func!r}")
        if acq_optimizer not in ACQ_OPTIMIZERS:
            raise ValueError(
                f"acq_optimizer must be one of {ACQ_OPTIMIZERS}, got {acq_optimizer!r}"
            )
        for name, value in (("xi", xi), ("kappa", kappa)):
            if isinstance(value, bool) or not isinstance(value, (int, float, np.number)):
                raise TypeError(f"{name} must be a number, got {value!r}")
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be finite and >= 0, got {value!r}")
        self._acq_func = acq_func
        self._acq_kwargs = {"xi": float(xi), "kappa": float(kappa)}
        self._n_points = _count(n_points, "n_points", 1, N_POINTS_MAX)
        self._acq_optimizer = acq_optimizer
        self._gp_restarts = _count(gp_restarts, "gp_restarts", 0, GP_RESTARTS_MAX)
        skopt = import_optional("skopt", purpose="the 'bo' optimizer")
        self._space = skopt.space.Space([(0.0, 1.0)] * self.n_dims)
        self._initial = np.asarray(
            skopt.sampler.Lhs(criterion="maximin", iterations=100).generate(
                self._space.dimensions, self._n_initial, random_state=self._seed()
            ),
            dtype=np.float64,
        ).reshape(self._n_initial, self.n_dims)
        self._n_initial_used = 0
        self._x: list[np.ndarray] = []  # told points, unit box
        self._y: list[float] = []  # told values (penalties where failed)
        self._failed: list[bool] = []
        self._model: Any = None  # GP fitted to the told points, None if stale
        self._theta: np.ndarray | None = None  # last fitted log-hyperparameters (warm start)

    def _seed(self) -> int:
        return int(self._rng.integers(2**31 - 1))

    # --- hooks -------------------------------------------------------------------------------

    def _tell(
        self, ids: tuple[int, ...], x: np.ndarray, values: np.ndarray, failed: np.ndarray
    ) -> None:
        self._x.extend(np.array(x))
        self._y.extend(float(v) for v in values)
        self._failed.extend(bool(f) for f in failed)
        self._model = None

    def _ask(self, ids: tuple[int, ...]) -> np.ndarray:
        n = len(ids)
        pending = self._pending_unit()
        out: list[np.ndarray] = []
        # The initial design is handed out in order, whatever has been told meanwhile.
        while len(out) < n and self._n_initial_used < self._n_initial:
            out.append(self._initial[self._n_initial_used])
            self._n_initial_used += 1
        if len(out) < n:
            if sum(not f for f in self._failed) < 2:
                # No model without two real values: keep sampling the box uniformly.
                out.extend(self._rng.random((n - len(out), self.n_dims)))
            else:
                out.extend(self._believer_batch(n - len(out), np.vstack([pending, *out])))
        return np.array(out)

    def _backend_versions(self) -> dict[str, str]:
        import sklearn
        import skopt

        return {"scikit-optimize": str(skopt.__version__), "scikit-learn": sklearn.__version__}

    # --- the batch ---------------------------------------------------------------------------

    def _believer_batch(self, n: int, believers: np.ndarray) -> list[np.ndarray]:
        """The next n points by the Kriging believer loop, given (p, d) pending ``believers``."""
        from sklearn.base import clone
        from threadpoolctl import threadpool_limits

        X, y = self._training_data()
        chosen: list[np.ndarray] = []
        with threadpool_limits(limits=1, user_api="blas"), warnings.catch_warnings():
            # Fits with fixed hyperparameters may warn about ill-conditioning near believers.
            warnings.simplefilter("ignore")
            gp = self._fitted_model(X, y)
            y_opt = float(np.min(y[~np.asarray(self._failed)]))
            fixed = clone(gp).set_params(kernel=self._fixed_kernel(gp), optimizer=None)
            model, Xb, yb = gp, X, y
            if len(believers):
                Xb = np.vstack([X, believers])
                yb = np.concatenate([y, gp.predict(believers)])
                model = clone(fixed).fit(Xb, yb)
            for _ in range(n):
                x = self._maximize_acquisition(model, y_opt)
                chosen.append(x)
                Xb = np.vstack([Xb, x])
                yb = np.append(yb, model.predict(x[None, :])[0])
                model = clone(fixed).fit(Xb, yb)
        return chosen

    def _training_data(self) -> tuple[np.ndarray, np.ndarray]:
        X = np.array(self._x)
        y = np.array(self._y)
        failed = np.asarray(self._failed)
        # Re-penalize failures with the current penalty, which knows every value told so far.
        y[failed] = self._failure_penalty()
        return X, y

    def _fitted_model(self, X: np.ndarray, y: np.ndarray) -> Any:
        """The GP with hyperparameters fitted to (X, y), once per batch, warm-started."""
        if self._model is not None:
            return self._model
        from skopt.learning.gaussian_process.kernels import WhiteKernel
        from skopt.utils import cook_estimator

        gp = cook_estimator(
            "GP",
            space=self._space,
            random_state=self._seed(),
            n_restarts_optimizer=self._gp_restarts if self._theta is None else 0,
        )
        # cook_estimator leaves the noise term to fit(); add it here to warm-start all of theta.
        kernel = gp.kernel + WhiteKernel()
        if self._theta is not None:
            kernel = kernel.clone_with_theta(self._theta)
        gp.set_params(kernel=kernel)
        with warnings.catch_warnings():
            # Hyperparameters at their bounds (e.g. no noise) are warned about; the fit is fine.
            warnings.simplefilter("ignore")
            gp.fit(X, y)
        noise = max(float(gp.noise_ or 0.0), 1e-5)  # WhiteKernel's lower bound
        self._theta = np.append(gp.kernel_.k1.theta, np.log(noise))
        self._model = gp
        return gp

    @staticmethod
    def _fixed_kernel(gp: Any) -> Any:
        """The fitted kernel with its noise level, all hyperparameters fixed."""
        from skopt.learning.gaussian_process.kernels import WhiteKernel

        # skopt zeroes the fitted noise inside kernel_ (to predict the noise-free f) and keeps
        # it in noise_; the believer refits need it back in K.
        noise = max(float(gp.noise_ or 0.0), 1e-10)
        return gp.kernel_.k1 + WhiteKernel(noise_level=noise, noise_level_bounds="fixed")

    def _acquisition(self, X: np.ndarray, model: Any, y_opt: float) -> np.ndarray:
        """(m,) acquisition values of (m, d) points, lower is better (skopt's convention)."""
        from skopt.acquisition import gaussian_ei, gaussian_lcb, gaussian_pi

        if self._acq_func == "EI":
            return cast(
                "np.ndarray", -gaussian_ei(X, model, y_opt=y_opt, xi=self._acq_kwargs["xi"])
            )
        if self._acq_func == "PI":
            return cast(
                "np.ndarray", -gaussian_pi(X, model, y_opt=y_opt, xi=self._acq_kwargs["xi"])
            )
        return cast("np.ndarray", gaussian_lcb(X, model, kappa=self._acq_kwargs["kappa"]))

    def _maximize_acquisition(self, model: Any, y_opt: float) -> np.ndarray:
        """The acquisition's best point in the unit box."""
        posterior = _Posterior(model)
        candidates = self._rng.random((self._n_points, self.n_dims))
        values = self._acquisition(candidates, posterior, y_opt)
        k = int(np.argmin(values))
        best, best_value = candidates[k], values[k]
        if self._acq_optimizer == "sampling":
            # Zoom in: two rounds of candidates in boxes of +-5 % and +-0.5 % around the best;
            # close to L-BFGS polishing on smooth functions at about half the time per batch.
            for half_width in _ZOOM:
                local = best + half_width * (2.0 * self._rng.random((_N_ZOOM, self.n_dims)) - 1.0)
                local = np.clip(local, 0.0, 1.0)
                local_values = self._acquisition(local, posterior, y_opt)
                k = int(np.argmin(local_values))
                if local_values[k] < best_value:
                    best, best_value = local[k], local_values[k]
        else:
            from scipy.optimize import fmin_l_bfgs_b
            from skopt.acquisition import gaussian_acquisition_1D

            # skopt's own polishing step: value and gradient of one point from its GP.
            x, value, _ = fmin_l_bfgs_b(
                gaussian_acquisition_1D,
                best,
                args=(model, y_opt, self._acq_func, self._acq_kwargs),
                bounds=[(0.0, 1.0)] * self.n_dims,
                maxiter=20,
            )
            if np.all(np.isfinite(x)) and value <= best_value:
                best = x
        return cast("np.ndarray", np.clip(best, 0.0, 1.0))
