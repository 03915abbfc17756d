/* greybench's virtual sensor (core/fmu/fmu.h, export-fmu --virtual-sensor): the fitted model's
   extended Kalman filter as a Co-Simulation FMU. Appended to runtime.c (the state machine, the
   logging, the instance, the input derivatives and a step's checks) when the generated part
   defines GB_VIRTUAL_SENSOR and

     void gb_dynamics(const double* slots, double* out)     f (n), J = df/dx (n x n, row-major),
                                                            sigma (n)
     void gb_measurement(const double* slots, double* out)  h (p), H = dh/dx (p x n, row-major),
                                                            S (p)
     GB_DELAY_MAX, gb_delay[]    each output's delay in samples: y_{o,k} sees x_{k-d_o}
     GB_FOH                      1: the inputs interpolated linearly between samples (else held)
     GB_P0                       P0, as the model's filter starts: 1 "ctsm", gathered over the
                                 first interval from P = 0 at x0; 2 "stationary", the solution
                                 of J P + P J' + diag(sigma^2) = 0 at x0 and the first row's
                                 inputs; 0 gb_P0_start (n x n, row-major)
     gb_measured_name[]          the measurements, for messages

   Value references, Real: the inputs u (m), the measurements y (p); the outputs: the filtered
   states (n), their sd (n), the predicted states (n), their sd (n), the predicted outputs (p),
   their sd (p), the innovations (p); the parameters (k). Boolean: each measurement's validity
   (p), then `ready`.

   The filter is greybench's (core/filter/ekf.h). At state index j the prior (x, P) is updated
   with every valid y_{o, j+d_o}, output after output, each a scalar update linearised at the
   prior; then the moment equations dx = f, dP = J P + P J' + diag(sigma^2) are integrated to
   t_{j+1} by Dormand-Prince 5(4) with greybench's step-size rules (core/ode/ode.cpp: the same
   trial steps, error norm and step proposals carried from interval to interval), so it takes
   greybench's steps. A measurement given with row k belongs to state k - d_o, so the filter
   runs D = max d_o rows behind the newest and keeps the rows it still needs; with the first-
   order hold a state's time update also waits for the next row's input.

   fmi2DoStep(t_k, h) takes row k = (t_k, u, y, validity) as set before the call, and then
     - takes the filter as far as the rows allow: the update of state k - D (nothing while
       k < D; ready turns true with the first), and its time update when its interval's end is
       known (the next row's input with the first-order hold; t_k + h with the inputs held). The
       filtered states are x_{j|j} of the newest state updated, the innovations those of its
       measurements, y_{o, j+d_o} - h_o at the prior (0 where not valid);
     - predicts from there through the rows kept to t_{k+1} = t_k + h: the predicted states are
       x_{k+1} given every measurement so far, and the predicted outputs y_{o,k+1} (h at the
       prior of state k + 1 - d_o) with sd sqrt(H P H' + S). Over the newest interval the inputs
       are held, or ramped by fmi2SetRealInputDerivatives: with the first-order hold and
       without them, a prediction of a state after the newest row is the held input's.
   The outputs read after the step are these: none depends on an input set after it. */

#define GB_NZ (GB_N_STATES + GB_N_STATES * (GB_N_STATES + 1) / 2)
#define GB_RING (GB_DELAY_MAX + 2)
#define GB_NP GB_MAX1(GB_N_OUTPUTS)
#define GB_NU GB_MAX1(GB_N_INPUTS)

#define GB_SVR_INPUT GB_VR_INPUT /* 0: runtime.c's input range */
#define GB_SVR_MEASURED (GB_SVR_INPUT + GB_N_INPUTS)
#define GB_SVR_FILTERED (GB_SVR_MEASURED + GB_N_OUTPUTS)
#define GB_SVR_FILTERED_SD (GB_SVR_FILTERED + GB_N_STATES)
#define GB_SVR_PREDICTED (GB_SVR_FILTERED_SD + GB_N_STATES)
#define GB_SVR_PREDICTED_SD (GB_SVR_PREDICTED + GB_N_STATES)
#define GB_SVR_Y_PRED (GB_SVR_PREDICTED_SD + GB_N_STATES)
#define GB_SVR_Y_SD (GB_SVR_Y_PRED + GB_N_OUTPUTS)
#define GB_SVR_RESIDUAL (GB_SVR_Y_SD + GB_N_OUTPUTS)
#define GB_SVR_PARAMETER (GB_SVR_RESIDUAL + GB_N_OUTPUTS)
#define GB_SVR_END (GB_SVR_PARAMETER + GB_N_PARAMETERS)
#define GB_BVR_READY (GB_N_OUTPUTS)

typedef struct {
  double t;
  double u[GB_NU];
  double y[GB_NP];
  fmi2Boolean valid[GB_NP];
} gbRow;

/* Dormand-Prince 5(4) on the packed moments, with the step proposal it carries. */
typedef struct {
  double x[GB_NZ], dxdt[GB_NZ], x_new[GB_NZ], dxdt_new[GB_NZ], stages[6 * GB_NZ];
  double magnitude[GB_NZ]; /* the error test's scale at x (gb_magnitudes) */
  double first_step;       /* the step the last interval's first step proposed (0: none) */
} gbOde;

/* The inputs over [t0, t0 + dt]: u0, or from u0 to u1 (u1 null: held). */
typedef struct {
  const double* u0;
  const double* u1;
  double t0, dt;
} gbInterval;

typedef struct gbSensor {
  double y_in[GB_NP];
  fmi2Boolean valid_in[GB_NP];
  gbRow rows[GB_RING]; /* row r at r % GB_RING */
  long k;              /* rows taken so far */
  long j;              /* the filter's state index */
  fmi2Boolean updated; /* z is state j's posterior (else its prior) */
  double z[GB_NZ];     /* the filter's moments at state j: x, P packed */
  gbOde ode;           /* the filter's integrator */
  gbOde scratch;       /* the prediction's */
  fmi2Boolean ready;
  double filtered[GB_N_STATES], filtered_sd[GB_N_STATES];
  double predicted[GB_N_STATES], predicted_sd[GB_N_STATES];
  double y_pred[GB_NP], y_sd[GB_NP], residual[GB_NP];
} gbSensor;

static const double gb_kC[6] = {0.0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1.0};
static const double gb_kA[6][5] = {
    {0},
    {1.0 / 5},
    {3.0 / 40, 9.0 / 40},
    {44.0 / 45, -56.0 / 15, 32.0 / 9},
    {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
    {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656}};
static const double gb_kB[6] = {35.0 / 384,     0.0,      500.0 / 1113, 125.0 / 192,
                                -2187.0 / 6784, 11.0 / 84};
#define GB_KE1 (35.0 / 384 - 5179.0 / 57600)
#define GB_KE3 (500.0 / 1113 - 7571.0 / 16695)
#define GB_KE4 (125.0 / 192 - 393.0 / 640)
#define GB_KE5 (-2187.0 / 6784 - -92097.0 / 339200)
#define GB_KE6 (11.0 / 84 - 187.0 / 2100)
#define GB_KE7 (-1.0 / 40)

static gbSensor* gb_sensor(gbInstance* c) { return (gbSensor*)c->sensor; }

static int gb_sensor_new(gbInstance* c) {
  c->sensor = c->callbacks.allocateMemory(1, sizeof(gbSensor));
  return c->sensor != NULL;
}

static void gb_sensor_free(gbInstance* c) {
  if (c->sensor) c->callbacks.freeMemory(c->sensor);
  c->sensor = NULL;
}

/* Back to the start: no rows, the outputs at the initial state, every measurement valid. */
static void gb_sensor_reset(gbInstance* c) {
  gbSensor* s = gb_sensor(c);
  int i;
  memset(s, 0, sizeof *s);
  for (i = 0; i < GB_N_STATES; ++i) s->filtered[i] = s->predicted[i] = gb_x_start[i];
  for (i = 0; i < GB_N_OUTPUTS; ++i) s->valid_in[i] = fmi2True;
}

/* P (n x n, symmetric) from the packed moments: column b, rows a >= b, as greybench packs. */
static void gb_unpack(const double* z, double* P) {
  const double* packed = z + GB_N_STATES;
  int a, b;
  for (b = 0; b < GB_N_STATES; ++b)
    for (a = b; a < GB_N_STATES; ++a) P[b * GB_N_STATES + a] = P[a * GB_N_STATES + b] = *packed++;
}

static void gb_pack(const double* x, const double* P, double* z) {
  double* packed = z + GB_N_STATES;
  int a, b;
  for (a = 0; a < GB_N_STATES; ++a) z[a] = x[a];
  for (b = 0; b < GB_N_STATES; ++b)
    for (a = b; a < GB_N_STATES; ++a) *packed++ = P[a * GB_N_STATES + b];
}

static void gb_sensor_slots(const gbInstance* c, const double* x, const gbInterval* iv, double t,
                            double* slots) {
  int i;
  for (i = 0; i < GB_N_STATES; ++i) slots[i] = x[i];
  if (iv->u1) {
    const double f = (t - iv->t0) / iv->dt;
    for (i = 0; i < GB_N_INPUTS; ++i)
      slots[GB_SLOT_INPUT + i] = iv->u0[i] + f * (iv->u1[i] - iv->u0[i]);
  } else {
    for (i = 0; i < GB_N_INPUTS; ++i) slots[GB_SLOT_INPUT + i] = iv->u0[i];
  }
  for (i = 0; i < GB_N_PARAMETERS; ++i) slots[GB_SLOT_PARAMETER + i] = c->theta[i];
  slots[GB_SLOT_TIME] = t;
}

/* dz = (f, J P + P J' + diag sigma^2) at (t, z), as core/filter/moments.cpp sums it; 0 where a
   value is not finite. */
static int gb_moments(const gbInstance* c, const gbInterval* iv, double t, const double* z,
                      double* dz) {
  double slots[GB_N_SLOTS], out[GB_N_STATES * (GB_N_STATES + 2)];
  double P[GB_N_STATES * GB_N_STATES], M[GB_N_STATES * GB_N_STATES];
  const double* J = out + GB_N_STATES;
  const double* sigma = out + GB_N_STATES + GB_N_STATES * GB_N_STATES;
  double* d = dz + GB_N_STATES;
  int a, b, k, finite = 1;
  gb_sensor_slots(c, z, iv, t, slots);
  gb_dynamics(slots, out);
  gb_unpack(z, P);
  /* M = P J': M(b, a) = (J P)_ab, summed over k in order */
  for (b = 0; b < GB_N_STATES; ++b)
    for (a = 0; a < GB_N_STATES; ++a) {
      double sum = 0.0;
      for (k = 0; k < GB_N_STATES; ++k) sum += P[b * GB_N_STATES + k] * J[a * GB_N_STATES + k];
      M[b * GB_N_STATES + a] = sum;
    }
  for (a = 0; a < GB_N_STATES; ++a) finite &= isfinite(dz[a] = out[a]) != 0;
  for (b = 0; b < GB_N_STATES; ++b) {
    finite &=
        isfinite(*d++ = M[b * GB_N_STATES + b] + M[b * GB_N_STATES + b] + sigma[b] * sigma[b]) != 0;
    for (a = b + 1; a < GB_N_STATES; ++a)
      finite &= isfinite(*d++ = M[a * GB_N_STATES + b] + M[b * GB_N_STATES + a]) != 0;
  }
  return finite;
}

/* The error test's scale m at the packed moments z, as core/filter/moments.cpp's Magnitudes:
   sqrt(x_i^2 + P_ii) for a mean, |P_aa| for a variance, sqrt(|P_aa P_bb|) for a covariance. */
static void gb_magnitudes(const double* z, double* m) {
  int a, b, k = GB_N_STATES, diagonal[GB_N_STATES];
  for (b = 0; b < GB_N_STATES; ++b) { /* P_bb's place in the packed columns */
    diagonal[b] = k;
    k += GB_N_STATES - b;
  }
  for (a = 0; a < GB_N_STATES; ++a) m[a] = sqrt(z[a] * z[a] + fabs(z[diagonal[a]]));
  k = GB_N_STATES;
  for (b = 0; b < GB_N_STATES; ++b) {
    const double var_b = fabs(z[diagonal[b]]);
    m[k++] = var_b;
    for (a = b + 1; a < GB_N_STATES; ++a) m[k++] = sqrt(fabs(z[diagonal[a]]) * var_b);
  }
}

/* One trial step from (t, x) with k1 = F(t, x): x_new, k7 = F(t + h, x_new), and the scaled
   error max_i |err_i| / (atol + rtol (m_i + h |k1_i|)), m = gb_magnitudes(x), NaN where a stage
   is not finite. */
static double gb_trial(const gbInstance* c, const gbInterval* iv, gbOde* e, double t, double h) {
  double* k2 = e->stages;
  double* k3 = k2 + GB_NZ;
  double* k4 = k3 + GB_NZ;
  double* k5 = k4 + GB_NZ;
  double* k6 = k5 + GB_NZ;
  double* y = k6 + GB_NZ;
  const double* x = e->x;
  const double* k1 = e->dxdt;
  double worst = 0.0;
  int i, finite = 1;
  const double a21 = h * gb_kA[1][0];
  const double a31 = h * gb_kA[2][0], a32 = h * gb_kA[2][1];
  const double a41 = h * gb_kA[3][0], a42 = h * gb_kA[3][1], a43 = h * gb_kA[3][2];
  const double a51 = h * gb_kA[4][0], a52 = h * gb_kA[4][1], a53 = h * gb_kA[4][2],
               a54 = h * gb_kA[4][3];
  const double a61 = h * gb_kA[5][0], a62 = h * gb_kA[5][1], a63 = h * gb_kA[5][2],
               a64 = h * gb_kA[5][3], a65 = h * gb_kA[5][4];
  const double b1 = h * gb_kB[0], b3 = h * gb_kB[2], b4 = h * gb_kB[3], b5 = h * gb_kB[4],
               b6 = h * gb_kB[5];
  const double e1 = h * GB_KE1, e3 = h * GB_KE3, e4 = h * GB_KE4, e5 = h * GB_KE5, e6 = h * GB_KE6,
               e7 = h * GB_KE7;
  for (i = 0; i < GB_NZ; ++i) y[i] = x[i] + a21 * k1[i];
  finite &= gb_moments(c, iv, t + h * gb_kC[1], y, k2);
  for (i = 0; i < GB_NZ; ++i) y[i] = x[i] + a31 * k1[i] + a32 * k2[i];
  finite &= gb_moments(c, iv, t + h * gb_kC[2], y, k3);
  for (i = 0; i < GB_NZ; ++i) y[i] = x[i] + a41 * k1[i] + a42 * k2[i] + a43 * k3[i];
  finite &= gb_moments(c, iv, t + h * gb_kC[3], y, k4);
  for (i = 0; i < GB_NZ; ++i) y[i] = x[i] + a51 * k1[i] + a52 * k2[i] + a53 * k3[i] + a54 * k4[i];
  finite &= gb_moments(c, iv, t + h * gb_kC[4], y, k5);
  for (i = 0; i < GB_NZ; ++i)
    y[i] = x[i] + a61 * k1[i] + a62 * k2[i] + a63 * k3[i] + a64 * k4[i] + a65 * k5[i];
  finite &= gb_moments(c, iv, t + h, y, k6);
  for (i = 0; i < GB_NZ; ++i)
    e->x_new[i] = x[i] + b1 * k1[i] + b3 * k3[i] + b4 * k4[i] + b5 * k5[i] + b6 * k6[i];
  finite &= gb_moments(c, iv, t + h, e->x_new, e->dxdt_new);
  if (!finite) return NAN;
  for (i = 0; i < GB_NZ; ++i) {
    const double err =
        e1 * k1[i] + e3 * k3[i] + e4 * k4[i] + e5 * k5[i] + e6 * k6[i] + e7 * e->dxdt_new[i];
    const double scale = GB_ATOL + GB_RTOL * (e->magnitude[i] + fabs(h) * fabs(k1[i]));
    const double r = fabs(err) / scale;
    if (r > worst) worst = r;
  }
  return worst;
}

/* z from t0 to t1 under error control, with core/ode/ode.cpp's rules: a step that leaves the
   model's domain is quartered, a rejected one shrunk by max(0.9 err^(-1/3), 1/5), an accepted
   one grown by 0.9 max(err, 5^-5)^(-1/5) when err < 1/2; the first step's proposal carries to
   the next interval (not when that step was cut short to land on t1). 0 with a message on
   failure. */
static int gb_advance(gbInstance* c, gbOde* e, const gbInterval* iv, double t0, double t1,
                      double* z) {
  const double length = t1 - t0;
  double t = t0, dt;
  long attempt;
  int i, first = 1;
  for (i = 0; i < GB_NZ; ++i) e->x[i] = z[i];
  gb_magnitudes(e->x, e->magnitude);
  if (!gb_moments(c, iv, t, e->x, e->dxdt)) {
    gb_log(c, fmi2Error, "logStatusError",
           "fmi2DoStep: the moment equations are not finite at t = %g", t);
    return 0;
  }
  dt = e->first_step > 0.0 ? (e->first_step < length ? e->first_step : length) : length;
  for (attempt = 0;; ++attempt) {
    const double left = t1 - t;
    const int last = dt >= left;
    double dt_tried, error;
    if (attempt > 100000) {
      gb_log(c, fmi2Error, "logStatusError",
             "fmi2DoStep: more than 100000 steps in the interval from t = %g", t0);
      return 0;
    }
    if (last) dt = left;
    dt_tried = dt;
    error = gb_trial(c, iv, e, t, dt);
    if (isnan(error)) {
      dt = 0.25 * dt_tried;
    } else if (!(error > 1.0)) {
      for (i = 0; i < GB_NZ; ++i) {
        e->x[i] = e->x_new[i];
        e->dxdt[i] = e->dxdt_new[i];
      }
      dt = error < 0.5
               ? dt_tried * (0.9 * pow(error > pow(5.0, -5.0) ? error : pow(5.0, -5.0), -1.0 / 5))
               : dt_tried;
      if (first) {
        if (!last || dt_tried >= 0.5 * e->first_step || e->first_step == 0.0) e->first_step = dt;
        first = 0;
      }
      if (last) break;
      t += dt_tried;
      gb_magnitudes(e->x, e->magnitude);
    } else {
      const double shrink = 0.9 * pow(error, -1.0 / 3);
      dt = dt_tried * (shrink > 1.0 / 5 ? shrink : 1.0 / 5);
    }
    if (!(dt > 1e-14 * length)) {
      gb_log(c, fmi2Error, "logStatusError",
             "fmi2DoStep: the step size fell below 1e-14 of the interval from t = %g (the "
             "moment equations are not finite or too stiff there)",
             t0);
      return 0;
    }
  }
  for (i = 0; i < GB_NZ; ++i) z[i] = e->x[i];
  return 1;
}

static const gbRow* gb_row(const gbSensor* s, long r) { return &s->rows[r % GB_RING]; }

/* The time of row r + 1, and where the inputs after row r go: the next row's, or (after the
   newest) t_k + h, ramped by the input derivatives where the importer gave them. */
static void gb_interval(gbInstance* c, long r, double h, double* u_end, gbInterval* iv,
                        double* t1) {
  const gbSensor* s = gb_sensor(c);
  const gbRow* row = gb_row(s, r);
  int i;
  iv->u0 = row->u;
  iv->t0 = row->t;
  iv->u1 = NULL;
  if (r + 1 < s->k) {
    *t1 = gb_row(s, r + 1)->t;
    if (GB_FOH) iv->u1 = gb_row(s, r + 1)->u;
  } else {
    int ramped = 0;
    *t1 = row->t + h;
    for (i = 0; i < GB_N_INPUTS; ++i) {
      u_end[i] = row->u[i] + c->du[i] * h;
      ramped |= c->du[i] != 0.0;
    }
    if (ramped) iv->u1 = u_end;
  }
  iv->dt = *t1 - iv->t0;
}

/* h, H and S at state x, time t and row r's inputs; 0 with a message if not finite. */
static int gb_measure(gbInstance* c, long r, double t, const double* x, double* out) {
  const gbRow* row = gb_row(gb_sensor(c), r);
  gbInterval iv;
  double slots[GB_N_SLOTS];
  int i;
  iv.u0 = row->u;
  iv.u1 = NULL;
  iv.t0 = t;
  iv.dt = 1.0;
  gb_sensor_slots(c, x, &iv, t, slots);
  gb_measurement(slots, out);
  for (i = 0; i < GB_N_OUTPUTS * (GB_N_STATES + 2); ++i) {
    if (!isfinite(out[i])) {
      gb_log(c, fmi2Error, "logStatusError",
             "fmi2DoStep: the observation, its derivative or its variance is not finite at "
             "t = %g",
             t);
      return 0;
    }
  }
  return 1;
}

/* sd of output o at (P, measurement out): sqrt(H P H' + S). */
static double gb_output_sd(const double* P, const double* out, int o) {
  const double* H = out + GB_N_OUTPUTS + o * GB_N_STATES;
  double v = out[GB_N_OUTPUTS + GB_N_OUTPUTS * GB_N_STATES + o];
  int a, b;
  for (a = 0; a < GB_N_STATES; ++a) {
    double row = 0.0;
    for (b = 0; b < GB_N_STATES; ++b) row += P[a * GB_N_STATES + b] * H[b];
    v += H[a] * row;
  }
  return v > 0.0 ? sqrt(v) : 0.0;
}

#if GB_P0 == 2
/* Solves K p = b in place by Gaussian elimination with partial pivoting (K m x m, row-major);
   0 when K is singular. */
static int gb_solve(double* K, double* b, int m) {
  int col, row, k;
  for (col = 0; col < m; ++col) {
    int pivot = col;
    for (row = col + 1; row < m; ++row)
      if (fabs(K[row * m + col]) > fabs(K[pivot * m + col])) pivot = row;
    if (!(fabs(K[pivot * m + col]) > 0.0)) return 0;
    if (pivot != col) {
      double t;
      for (k = 0; k < m; ++k) {
        t = K[col * m + k];
        K[col * m + k] = K[pivot * m + k];
        K[pivot * m + k] = t;
      }
      t = b[col];
      b[col] = b[pivot];
      b[pivot] = t;
    }
    for (row = col + 1; row < m; ++row) {
      const double f = K[row * m + col] / K[col * m + col];
      if (f == 0.0) continue;
      for (k = col; k < m; ++k) K[row * m + k] -= f * K[col * m + k];
      b[row] -= f * b[col];
    }
  }
  for (row = m - 1; row >= 0; --row) {
    double sum = b[row];
    for (k = row + 1; k < m; ++k) sum -= K[row * m + k] * b[k];
    b[row] = sum / K[row * m + row];
  }
  return 1;
}

/* P of J P + P J' + diag(q) = 0 (J row-major), symmetrised; 0 when the operator is singular. */
static int gb_lyapunov(gbInstance* c, const double* J, const double* q, double* P) {
  const int n = GB_N_STATES, m = GB_N_STATES * GB_N_STATES;
  double* K = (double*)c->callbacks.allocateMemory((size_t)m * (size_t)m, sizeof(double));
  double b[GB_N_STATES * GB_N_STATES];
  int i, j, k, solved;
  if (!K) return 0;
  /* vec(P) by columns: P_ij at i + j n; (J P + P J')_ij = sum_k J_ik P_kj + P_ik J_jk */
  for (i = 0; i < m * m; ++i) K[i] = 0.0;
  for (i = 0; i < m; ++i) b[i] = 0.0;
  for (j = 0; j < n; ++j)
    for (i = 0; i < n; ++i)
      for (k = 0; k < n; ++k) {
        K[(i + j * n) * m + (k + j * n)] += J[i * n + k];
        K[(i + j * n) * m + (i + k * n)] += J[j * n + k];
      }
  for (i = 0; i < n; ++i) b[i + i * n] = -q[i];
  solved = gb_solve(K, b, m);
  c->callbacks.freeMemory(K);
  if (!solved) return 0;
  for (i = 0; i < n; ++i)
    for (j = 0; j < n; ++j) P[i * n + j] = 0.5 * (b[i + j * n] + b[j + i * n]);
  return 1;
}

/* Whether the symmetric P (n x n) is positive definite (its Cholesky factorisation exists). */
static int gb_positive_definite(const double* P) {
  double L[GB_N_STATES * GB_N_STATES];
  int i, j, k;
  for (j = 0; j < GB_N_STATES; ++j) {
    double d = P[j * GB_N_STATES + j];
    for (k = 0; k < j; ++k) d -= L[j * GB_N_STATES + k] * L[j * GB_N_STATES + k];
    if (!(d > 0.0)) return 0;
    L[j * GB_N_STATES + j] = sqrt(d);
    for (i = j + 1; i < GB_N_STATES; ++i) {
      double v = P[i * GB_N_STATES + j];
      for (k = 0; k < j; ++k) v -= L[i * GB_N_STATES + k] * L[j * GB_N_STATES + k];
      L[i * GB_N_STATES + j] = v / L[j * GB_N_STATES + j];
    }
  }
  return 1;
}

/* "stationary": P0 of J P + P J' + diag(sigma^2) = 0 at x0, the first row's inputs and time. J
   must be stable (every eigenvalue's real part negative), which holds exactly when the solution
   for diag(1) in place of diag(sigma^2) is positive definite (Lyapunov's theorem). */
static int gb_stationary(gbInstance* c, const double* x0, double* P) {
  const gbRow* row = gb_row(gb_sensor(c), 0);
  double slots[GB_N_SLOTS], out[GB_N_STATES * (GB_N_STATES + 2)], q[GB_N_STATES];
  const double* sigma = out + GB_N_STATES + GB_N_STATES * GB_N_STATES;
  gbInterval iv;
  int i;
  iv.u0 = row->u;
  iv.u1 = NULL;
  iv.t0 = row->t;
  iv.dt = 1.0;
  gb_sensor_slots(c, x0, &iv, row->t, slots);
  gb_dynamics(slots, out);
  for (i = 0; i < GB_N_STATES * (GB_N_STATES + 2); ++i)
    if (!isfinite(out[i])) {
      gb_log(c, fmi2Error, "logStatusError",
             "fmi2DoStep: the dynamics are not finite at the initial state (t = %g)", row->t);
      return 0;
    }
  for (i = 0; i < GB_N_STATES; ++i) q[i] = 1.0;
  if (!gb_lyapunov(c, out + GB_N_STATES, q, P) || !gb_positive_definite(P)) {
    gb_log(c, fmi2Error, "logStatusError",
           "fmi2DoStep: initial_covariance \"stationary\" needs a stable linearisation at the "
           "initial state (t = %g), and it is not stable",
           row->t);
    return 0;
  }
  for (i = 0; i < GB_N_STATES; ++i) q[i] = sigma[i] * sigma[i];
  return gb_lyapunov(c, out + GB_N_STATES, q, P);
}
#endif

/* The measurement update of the moments z (x, P packed) at state j with the measurements of it
   that have arrived (rows up to `newest`): output after output, each a scalar update
   linearised at the prior (ŷ = h_o + H_o (x - x_prior), k = P H_o', R = H_o k + S_o,
   x += k ε/R, P -= k k'/R), as core/filter/ekf.cpp does. `residual` (may be null) gets each
   output's innovation at the prior, y - h_o (0 where not valid or not arrived). */
static int gb_measurements(gbInstance* c, long j, double* z, long newest, double* residual) {
  const gbSensor* s = gb_sensor(c);
  double x[GB_N_STATES], x_prior[GB_N_STATES], P[GB_N_STATES * GB_N_STATES], PHt[GB_N_STATES];
  double out[GB_NP * (GB_N_STATES + 2)];
  int o, a, b, measured = 0;
  for (a = 0; a < GB_N_STATES; ++a) x[a] = x_prior[a] = z[a];
  gb_unpack(z, P);
  for (o = 0; o < GB_N_OUTPUTS; ++o) {
    const gbRow* row = gb_row(s, j + gb_delay[o]);
    const double* H = out + GB_N_OUTPUTS + o * GB_N_STATES;
    double yhat, R, eps;
    if (residual) residual[o] = 0.0;
    if (j + gb_delay[o] > newest || !row->valid[o] || !isfinite(row->y[o])) continue;
    if (!measured && !gb_measure(c, j, gb_row(s, j)->t, x_prior, out)) return 0;
    measured = 1;
    if (residual) residual[o] = row->y[o] - out[o];
    yhat = out[o];
    R = out[GB_N_OUTPUTS + GB_N_OUTPUTS * GB_N_STATES + o];
    for (a = 0; a < GB_N_STATES; ++a) yhat += H[a] * (x[a] - x_prior[a]);
    for (a = 0; a < GB_N_STATES; ++a) {
      double sum = 0.0;
      for (b = 0; b < GB_N_STATES; ++b) sum += P[a * GB_N_STATES + b] * H[b];
      PHt[a] = sum;
    }
    for (a = 0; a < GB_N_STATES; ++a) R += H[a] * PHt[a];
    if (!(R > 0.0)) {
      gb_log(c, fmi2Error, "logStatusError",
             "fmi2DoStep: the innovation variance of %s at t = %g is %g, not positive",
             gb_measured_name[o], row->t, R);
      return 0;
    }
    eps = row->y[o] - yhat;
    for (a = 0; a < GB_N_STATES; ++a) x[a] += PHt[a] * (eps / R);
    for (a = 0; a < GB_N_STATES; ++a)
      for (b = 0; b < GB_N_STATES; ++b) P[a * GB_N_STATES + b] -= (1.0 / R) * PHt[a] * PHt[b];
  }
  if (measured) gb_pack(x, P, z);
  return 1;
}

/* The measurement update of the filter's state j with the measurements that see it (the prior
   first, at j = 0). */
static int gb_update(gbInstance* c, long j, double h) {
  gbSensor* s = gb_sensor(c);
  double x[GB_N_STATES], P[GB_N_STATES * GB_N_STATES];
  int a;
  if (j == 0) { /* the prior: x0, and P0 given or gathered over the first interval */
    for (a = 0; a < GB_N_STATES; ++a) x[a] = gb_x_start[a];
#if GB_P0 == 1
    double u_end[GB_NU], t1;
    gbInterval iv;
    for (a = 0; a < GB_N_STATES * GB_N_STATES; ++a) P[a] = 0.0;
    gb_pack(x, P, s->z);
    gb_interval(c, 0, h, u_end, &iv, &t1);
    if (!gb_advance(c, &s->ode, &iv, iv.t0, t1, s->z)) return 0;
    for (a = 0; a < GB_N_STATES; ++a) s->z[a] = x[a];
#elif GB_P0 == 2
    (void)h;
    if (!gb_stationary(c, x, P)) return 0;
    gb_pack(x, P, s->z);
#else
    (void)h;
    gb_pack(x, gb_P0_start, s->z);
#endif
  }
  if (!gb_measurements(c, j, s->z, s->k - 1, s->residual)) return 0;
  gb_unpack(s->z, P);
  for (a = 0; a < GB_N_STATES; ++a) {
    s->filtered[a] = s->z[a];
    s->filtered_sd[a] = P[a * GB_N_STATES + a] > 0.0 ? sqrt(P[a * GB_N_STATES + a]) : 0.0;
  }
  return 1;
}

/* The time update of the filter's state j to j + 1. */
static int gb_time_update(gbInstance* c, long j, double h) {
  gbSensor* s = gb_sensor(c);
  double u_end[GB_NU], t1;
  gbInterval iv;
  gb_interval(c, j, h, u_end, &iv, &t1);
  return gb_advance(c, &s->ode, &iv, iv.t0, t1, s->z);
}

/* From the filter's state through the rows kept to t_{k+1} = t_k + h, with every measurement that
   has arrived: the predicted states, and each output's prediction at row k + 1 (h at the prior
   of state k + 1 - d_o, before that state's own measurements). */
static int gb_predict_now(gbInstance* c, double h) {
  gbSensor* s = gb_sensor(c);
  double z[GB_NZ], P[GB_N_STATES * GB_N_STATES], out[GB_NP * (GB_N_STATES + 2)], u_end[GB_NU];
  double t1;
  const long newest = s->k - 1;
  long state = s->j;
  int o, a;
  gbInterval iv;
  for (a = 0; a < GB_NZ; ++a) z[a] = s->z[a];
  s->scratch.first_step = s->ode.first_step;
  if (s->updated) { /* a posterior: to the next state's prior first */
    gb_interval(c, state, h, u_end, &iv, &t1);
    if (!gb_advance(c, &s->scratch, &iv, iv.t0, t1, z)) return 0;
    ++state;
  }
  for (;; ++state) {
    int measured = 0;
    for (o = 0; o < GB_N_OUTPUTS; ++o) {
      if (state + gb_delay[o] != newest + 1) continue;
      /* state newest + 1 has no row yet: t_k + h, and the newest row's inputs */
      if (!measured &&
          !gb_measure(c, state <= newest ? state : newest,
                      state <= newest ? gb_row(s, state)->t : gb_row(s, newest)->t + h, z, out))
        return 0;
      measured = 1;
      gb_unpack(z, P);
      s->y_pred[o] = out[o];
      s->y_sd[o] = gb_output_sd(P, out, o);
    }
    if (state > newest) break;
    /* the measurements of this state that have arrived (the filter uses them, with the rest,
       once they are all there) */
    if (!gb_measurements(c, state, z, newest, NULL)) return 0;
    gb_interval(c, state, h, u_end, &iv, &t1);
    if (!gb_advance(c, &s->scratch, &iv, iv.t0, t1, z)) return 0;
  }
  gb_unpack(z, P);
  for (a = 0; a < GB_N_STATES; ++a) {
    s->predicted[a] = z[a];
    s->predicted_sd[a] = P[a * GB_N_STATES + a] > 0.0 ? sqrt(P[a * GB_N_STATES + a]) : 0.0;
  }
  return 1;
}

static fmi2Status gb_derivatives(gbInstance* c, double* f) {
  (void)f;
  gb_log(c, fmi2Error, "logStatusError", "a virtual sensor has no derivatives");
  return fmi2Error;
}

/* ---- values ------------------------------------------------------------------------------- */

fmi2Status fmi2GetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[]) {
  gbInstance* c = (gbInstance*)component;
  const gbSensor* s;
  size_t k;
  if (!gb_allowed(c, "fmi2GetReal", gbInitialization | gbStepComplete | gbTerminated | gbError))
    return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return fmi2Error;
  s = gb_sensor(c);
  for (k = 0; k < nvr; ++k) {
    const fmi2ValueReference r = vr[k];
    if (r < GB_SVR_MEASURED)
      value[k] = c->u[r - GB_SVR_INPUT];
    else if (r < GB_SVR_FILTERED)
      value[k] = s->y_in[r - GB_SVR_MEASURED];
    else if (r < GB_SVR_FILTERED_SD)
      value[k] = s->filtered[r - GB_SVR_FILTERED];
    else if (r < GB_SVR_PREDICTED)
      value[k] = s->filtered_sd[r - GB_SVR_FILTERED_SD];
    else if (r < GB_SVR_PREDICTED_SD)
      value[k] = s->predicted[r - GB_SVR_PREDICTED];
    else if (r < GB_SVR_Y_PRED)
      value[k] = s->predicted_sd[r - GB_SVR_PREDICTED_SD];
    else if (r < GB_SVR_Y_SD)
      value[k] = s->y_pred[r - GB_SVR_Y_PRED];
    else if (r < GB_SVR_RESIDUAL)
      value[k] = s->y_sd[r - GB_SVR_Y_SD];
    else if (r < GB_SVR_PARAMETER)
      value[k] = s->residual[r - GB_SVR_RESIDUAL];
    else if (r < GB_SVR_END)
      value[k] = c->theta[r - GB_SVR_PARAMETER];
    else {
      gb_log(c, fmi2Error, "logStatusError", "fmi2GetReal: no variable has value reference %u",
             (unsigned)r);
      return fmi2Error;
    }
  }
  return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[]) {
  gbInstance* c = (gbInstance*)component;
  size_t k;
  if (!gb_allowed(c, "fmi2SetReal", gbInstantiated | gbInitialization | gbStepComplete))
    return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return fmi2Error;
  for (k = 0; k < nvr; ++k) {
    const fmi2ValueReference r = vr[k];
    if (r < GB_SVR_MEASURED) {
      c->u[r - GB_SVR_INPUT] = value[k];
    } else if (r < GB_SVR_FILTERED) {
      gb_sensor(c)->y_in[r - GB_SVR_MEASURED] = value[k];
    } else if (r >= GB_SVR_PARAMETER && r < GB_SVR_END) {
      c->theta[r - GB_SVR_PARAMETER] = value[k];
    } else {
      gb_log(c, fmi2Error, "logStatusError",
             "fmi2SetReal: value reference %u is not an input, a measurement or a parameter (the "
             "filter's outputs are computed, never set)",
             (unsigned)r);
      return fmi2Error;
    }
  }
  return fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[]) {
  gbInstance* c = (gbInstance*)component;
  size_t k;
  if (!gb_allowed(c, "fmi2GetBoolean", gbInitialization | gbStepComplete | gbTerminated | gbError))
    return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return fmi2Error;
  for (k = 0; k < nvr; ++k) {
    if (vr[k] < GB_BVR_READY) {
      value[k] = gb_sensor(c)->valid_in[vr[k]];
    } else if (vr[k] == GB_BVR_READY) {
      value[k] = gb_sensor(c)->ready;
    } else {
      gb_log(c, fmi2Error, "logStatusError", "fmi2GetBoolean: no variable has value reference %u",
             (unsigned)vr[k]);
      return fmi2Error;
    }
  }
  return fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component component, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[]) {
  gbInstance* c = (gbInstance*)component;
  size_t k;
  if (!gb_allowed(c, "fmi2SetBoolean", gbInstantiated | gbInitialization | gbStepComplete))
    return fmi2Error;
  if (nvr > 0 && (!vr || !value)) return fmi2Error;
  for (k = 0; k < nvr; ++k) {
    if (vr[k] >= GB_BVR_READY) {
      gb_log(c, fmi2Error, "logStatusError",
             "fmi2SetBoolean: value reference %u is not a measurement's validity", (unsigned)vr[k]);
      return fmi2Error;
    }
    gb_sensor(c)->valid_in[vr[k]] = value[k] ? fmi2True : fmi2False;
  }
  return fmi2OK;
}

GB_NO_VARIABLES(fmi2GetInteger, fmi2Integer, )
GB_NO_VARIABLES(fmi2GetString, fmi2String, )
GB_NO_VARIABLES(fmi2SetInteger, fmi2Integer, const)
GB_NO_VARIABLES(fmi2SetString, fmi2String, const)

/* ---- Co-Simulation: the filter's step ------------------------------------------------------ */

fmi2Status fmi2DoStep(fmi2Component component, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize,
                      fmi2Boolean noSetFMUStatePriorToCurrentPoint) {
  gbInstance* c = (gbInstance*)component;
  gbSensor* s;
  gbRow* row;
  int i;
  (void)noSetFMUStatePriorToCurrentPoint;
  if (!gb_step_allowed(c, currentCommunicationPoint, communicationStepSize)) return fmi2Error;
  s = gb_sensor(c);
  row = &s->rows[s->k % GB_RING];
  row->t = currentCommunicationPoint;
  for (i = 0; i < GB_N_INPUTS; ++i) row->u[i] = c->u[i];
  for (i = 0; i < GB_N_OUTPUTS; ++i) {
    row->y[i] = s->y_in[i];
    row->valid[i] = s->valid_in[i];
  }
  ++s->k;
  /* The filter goes as far as the rows allow: state j's update needs the rows up to j + D (and
     for "ctsm" with the first-order hold, P0 needs row 1), its time update the next row's
     input with the first-order hold, else only the interval's end. */
  for (;;) {
    const long newest = s->k - 1;
    if (!s->updated) {
      if (s->j + GB_DELAY_MAX > newest || (s->j == 0 && GB_P0 == 1 && GB_FOH && newest < 1)) break;
      if (!gb_update(c, s->j, communicationStepSize)) goto failed;
      s->updated = fmi2True;
      s->ready = fmi2True;
    }
    if (s->j > newest || (GB_FOH && s->j == newest)) break;
    if (!gb_time_update(c, s->j, communicationStepSize)) goto failed;
    ++s->j;
    s->updated = fmi2False;
  }
  if (s->ready && !gb_predict_now(c, communicationStepSize)) goto failed;
  gb_step_done(c, currentCommunicationPoint, communicationStepSize);
  return fmi2OK;
failed:
  c->state = gbError;
  return fmi2Error;
}
