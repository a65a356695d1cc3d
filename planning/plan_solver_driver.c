/* drivestyle: batch driver of the generated interior-point step (planning/plan_solver.py). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

static int all_finite(const double* v, int n) {
  for (int i = 0; i < n; ++i) if (!(v[i] - v[i] == 0.0)) return 0;
  return 1;
}

static void call_ineq(const double* w, const double* p, const double* b, double* h,
                      casadi_int* iw, casadi_real* wk) {
  const casadi_real* arg[DS_INEQ_SZ_ARG]; casadi_real* res[DS_INEQ_SZ_RES];
  arg[0] = w; arg[1] = p; arg[2] = b; res[0] = h;
  ds_ipm_ineq(arg, res, iw, wk, 0);
}

/* Build problem i's guess from its source (mode 1: shifted by one stage, 2: copied). */
static void make_guess(double* s, const double* src, int mode, casadi_int* iw,
                       casadi_real* wk) {
  if (mode == 1) {
    for (int i = 0; i < DS_NW; ++i) s[i] = src[DS_WSHIFT[i]];
    for (int i = 0; i < DS_NL; ++i) s[DS_NW + i] = src[DS_NW + DS_LSHIFT[i]];
    for (int i = 0; i < DS_NH; ++i) {
      s[DS_NW + DS_NL + i] = src[DS_NW + DS_NL + DS_ZSHIFT[i]];
      s[DS_NW + DS_NL + DS_NH + i] = src[DS_NW + DS_NL + DS_NH + DS_ZSHIFT[i]];
    }
    /* the plan's new last state: F(ξ_N, u_{N-1}) of the source */
    const casadi_real* arg[DS_DYN_SZ_ARG]; casadi_real* res[DS_DYN_SZ_RES];
    arg[0] = src + DS_XN; arg[1] = src + DS_ULAST; res[0] = s + DS_XN;
    ds_ipm_dyn(arg, res, iw, wk, 0);
  } else {
    memcpy(s, src, sizeof(double) * DS_NS);
  }
}

/* Prepare a guess: ξ_0 = ξ0; a given guess (keep_t = 0) gets t = h(w); a source's t is
   kept (its complementarity is already small: the iterations stay near that solution's
   branch). Then t >= t_floor, z >= z_floor. */
static void prepare(double* s, const double* p, const double* b, double t_floor, double z_floor,
                    int keep_t, casadi_int* iw, casadi_real* wk) {
  for (int i = 0; i < 4; ++i) s[DS_X0 + i] = p[i];
  double* t = s + DS_NW + DS_NL;
  double* z = t + DS_NH;
  if (!keep_t) call_ineq(s, p, b, t, iw, wk);
  for (int i = 0; i < DS_NH; ++i) {
    if (!(t[i] > t_floor)) t[i] = t_floor;
    if (!(z[i] > z_floor)) z[i] = z_floor;
  }
}

/* Solve n problems in order. mode: 0 guess given in states, 1 shift of problem src,
   2 copy of problem src, 3 already solved (skipped). status: 0 converged, 1 failed,
   2 blocked (its source failed). tol = [stationarity, primal, complementarity,
   t_floor, z_floor]. */
int ds_solve(int n, double* states, const double* P, const double* bnd, const int* src,
             const int* mode, int max_iter, const double* tol, int* status, int* iters,
             double* diag_out) {
  casadi_int sz_arg, sz_res, sz_iw, sz_w;
  ds_ipm_step_work(&sz_arg, &sz_res, &sz_iw, &sz_w);
  casadi_int iw_n = sz_iw, w_n = sz_w;
  ds_ipm_ineq_work(&sz_arg, &sz_res, &sz_iw, &sz_w);
  if (sz_iw > iw_n) iw_n = sz_iw;
  if (sz_w > w_n) w_n = sz_w;
  ds_ipm_dyn_work(&sz_arg, &sz_res, &sz_iw, &sz_w);
  if (sz_iw > iw_n) iw_n = sz_iw;
  if (sz_w > w_n) w_n = sz_w;
  casadi_int* iw = (casadi_int*) malloc(sizeof(casadi_int) * (iw_n + 1));
  casadi_real* wk = (casadi_real*) malloc(sizeof(casadi_real) * (w_n + 1));
  double* next = (double*) malloc(sizeof(double) * DS_NS);
  if (!iw || !wk || !next) { free(iw); free(wk); free(next); return -1; }
  for (int i = 0; i < n; ++i) {
    if (mode[i] == 3) continue;
    double* s = states + (size_t) i * DS_NS;
    const double* p = P + (size_t) i * DS_NP;
    const double* b = bnd + (size_t) i * DS_NB;
    double* dg = diag_out + (size_t) i * DS_NDIAG;
    iters[i] = 0;
    if (mode[i] == 1 || mode[i] == 2) {
      int j = src[i];
      if (j < 0 || j >= i || status[j] != 0) { status[i] = 2; continue; }
      make_guess(s, states + (size_t) j * DS_NS, mode[i], iw, wk);
    }
    prepare(s, p, b, tol[3], tol[4], mode[i] != 0, iw, wk);
    status[i] = 1;
    double delta = 0.0, delta_last = 0.0;
    for (int it = 0; it < max_iter; ++it) {
      const casadi_real* arg[DS_STEP_SZ_ARG]; casadi_real* res[DS_STEP_SZ_RES];
      arg[0] = s; arg[1] = p; arg[2] = b; arg[3] = &delta;
      res[0] = next; res[1] = dg;
      ds_ipm_step(arg, res, iw, wk, 0);
      iters[i] = it + 1;
      if (!all_finite(dg, 3)) break;
      /* IPOPT's scaling of the dual residuals: multipliers up to the slack penalty rho_1 */
      double sum = 0.0;
      for (int m = DS_NW; m < DS_NW + DS_NL; ++m) sum += fabs(s[m]);
      for (int m = DS_NW + DS_NL + DS_NH; m < DS_NS; ++m) sum += fabs(s[m]);
      double s_d = sum / (DS_NL + DS_NH) / 100.0;
      if (s_d < 1.0) s_d = 1.0;
      if (dg[0] <= tol[0] * s_d && dg[1] <= tol[1] && dg[2] <= tol[2] * s_d) {
        status[i] = 0;
        break;
      }
      if (!(dg[3] > 1e-10) || !all_finite(next, DS_NS)) {
        /* wrong inertia (or a NaN step): regularise the primal Hessian, IPOPT's rule */
        delta = delta == 0.0 ? (delta_last == 0.0 ? 1e-4 : delta_last / 3.0) : 8.0 * delta;
        if (delta > 1e8) break;
        continue;
      }
      if (delta > 0) delta_last = delta;
      delta = 0.0;
      memcpy(s, next, sizeof(double) * DS_NS);
    }
  }
  free(iw); free(wk); free(next);
  return 0;
}
