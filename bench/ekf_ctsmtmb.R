# ctsmTMB (the peer, ../shared/peers/ctsmtmb; never a dependency) with its extended Kalman filter
# (method "ekf": RTMB tape of the whole filter, nlminb with the AD gradient) on greybench's EKF
# benchmarks (issue 15), for docs/benchmarks.md. bench/ekf_speed.sh drives it side by side with
# greybench-cli on the same data; each mode prints one JSON line per measurement.
#
#   Rscript bench/ekf_ctsmtmb.R loglik N FAST DATA.csv SUBSTEPS [REPEATS] [ROWS]
#       The tank chain of bench/loglik_bench.cpp (TankChain(N, FAST): N tanks, FAST = 1 adds the
#       fast sensor state m, tau = 0.002) at its parameter values k = 0.5, kin = 0.6, s = 0.02,
#       r = 0.001. Tapes the negative log-likelihood with SUBSTEPS RK4 steps per sample interval
#       (1 is ctsmTMB's default), then times REPEATS (default 21) evaluations of fn and REPEATS/4
#       of gr (the AD gradient, forward and reverse sweep), each at a new theta (TMB caches the
#       last x); prints the medians. ROWS: use only the first ROWS samples.
#   Rscript bench/ekf_ctsmtmb.R tanks DATA.csv [SUBSTEPS] [AT_FILE]
#       The Cascaded Tanks fit (assets/models/cascaded_tanks.json translated, below) from the model
#       file's start values with nlminb. AT_FILE (lines "name value"): also print log L at those
#       parameter values (greybench's optimum) through the same tape.
#   Rscript bench/ekf_ctsmtmb.R tanks-loglik DATA.csv SUBSTEPS AT_FILE
#       The same model's log L at its start values and at AT_FILE's, without a fit.
#   Rscript bench/ekf_ctsmtmb.R ou SUBSTEPS DATA.csv...
#       Ornstein-Uhlenbeck dx = -theta x dt + sigma dw, y = x + e, e ~ N(0, r), r = 0.01 known:
#       fits theta and sigma on each record (start at the truth 1, 0.5).
#
# Run R single-threaded (OMP_NUM_THREADS=1); the first model of a session compiles C++ (Rcpp, its
# filter and report functions): that is in "setup_s", not in "tape_s" (ctsmTMB's own timer of
# MakeADFun, the taping).
#
# Differences from greybench's models, forced by ctsmTMB:
# - Tank chain: P0 = 1e-4 I given explicitly (ctsmTMB takes a numeric initial covariance;
#   greybench's default "ctsm" P0 integrates the covariance equation over the first interval), so
#   the greybench model the driver writes states "initial_covariance" 1e-4 per state too. The fast
#   sensor has no diffusion: written "0*dw3" (ctsmTMB requires a dw term in every equation).
# - Cascaded Tanks: ctsmTMB's initial state is a number, not a parameter expression, so the
#   estimated initial levels h10, h20 enter through the shift z = h - h0 (z(0) = 0; the drift,
#   Jacobian and observation are those of h, so the EKF is the same); max(h, 1e-6) is written
#   0.5 (h + 1e-6 + sqrt((h - 1e-6)^2 + 1e-12)), within 5e-7 of it everywhere and equal to h to
#   double precision at the levels the fit visits (ctsmTMB's Deriv has no rule for max or pmax, and
#   the C++ it generates from the derivative of abs calls sign(double), which does not compile); P0 is
#   diag(s1^2, s2^2) * 4 = 4e-8 I (greybench's "ctsm" P0 with the fixed diffusion 1e-4 over one
#   interval of 4 s, to first order); the softplus terms are the model file's, verbatim.
# - OU: x0 = 0 and P0 = 0.125 (the stationary variance at the truth) in both tools.
suppressPackageStartupMessages(library(ctsmTMB))
args <- commandArgs(trailingOnly = TRUE)
mode <- args[1]

secs <- function(t0) as.numeric(difftime(Sys.time(), t0, units = "secs"))
# TMB returns its last value when fn is called again at the same x (11 us here against 2 ms), so
# every timed call gets a new x: theta (1 + 1e-9 i).
median_time <- function(f, x, repeats) {
  f(x)  # warm
  median(vapply(seq_len(repeats), function(i) {
    xi <- x * (1 + 1e-9 * i)
    t0 <- Sys.time(); f(xi); secs(t0)
  }, 0))
}
json_line <- function(x) {
  v <- vapply(names(x), function(k) {
    val <- x[[k]]
    if (is.character(val)) sprintf("\"%s\": \"%s\"", k, val)
    else if (length(val) == 1 && is.na(val)) sprintf("\"%s\": null", k)
    else sprintf("\"%s\": %.10g", k, val)
  }, "")
  cat("{", paste(v, collapse = ", "), "}\n", sep = "")
}

tank_chain <- function(n, fast) {
  m <- ctsmTMB$new()
  for (i in 1:n) {
    inflow <- if (i == 1) "kin*u" else sprintf("k*sqrt(h%d)", i - 1)
    m$addSystem(as.formula(sprintf("dh%d ~ (%s - k*sqrt(h%d))*dt + s*dw%d", i, inflow, i, i)))
  }
  if (fast) {
    m$addSystem(as.formula(sprintf("dm ~ (h%d - m)/tau*dt + 0*dw%d", n, n + 1)))
    m$addObs(y ~ m)
  } else {
    m$addObs(as.formula(sprintf("y ~ h%d", n)))
  }
  m$setVariance(y ~ r)
  m$addInput(u)
  m$setParameter(k = c(initial = 0.5, lower = 0.01, upper = 5),
                 kin = c(initial = 0.6, lower = 0.01, upper = 5),
                 s = c(initial = 0.02, lower = 1e-4, upper = 1),
                 r = c(initial = 0.001, lower = 1e-6, upper = 1))
  if (fast) m$setParameter(tau = c(initial = 0.002, lower = 1e-4, upper = 1))
  ns <- n + fast
  m$setInitialState(list(mean = rep(1.4, ns), cov = 1e-4 * diag(ns)))
  m
}

tanks_model <- function() {
  m <- ctsmTMB$new()
  # h = z + h0; max(h, 1e-6) as 0.5 (h + 1e-6 + sqrt((h - 1e-6)^2 + 1e-12)) (within 5e-7 of it);
  # o(z) = w log(1 + e^{z/w}) as in the model file
  m$addSystem(dz1 ~ (k4*u - k1*(0.5*(z1 + h10 + 1e-6 + sqrt((z1 + h10 - 1e-6)^2 + 1e-12)))^a1
                     - w*log(1 + exp((z1 + h10 - h1max)/w)))*dt + s1*dw1)
  m$addSystem(dz2 ~ (k1*(0.5*(z1 + h10 + 1e-6 + sqrt((z1 + h10 - 1e-6)^2 + 1e-12)))^a1
                     + kx*w*log(1 + exp((z1 + h10 - h1max)/w))
                     - k3*(0.5*(z2 + h20 + 1e-6 + sqrt((z2 + h20 - 1e-6)^2 + 1e-12)))^a2
                     - w*log(1 + exp((z2 + h20 - h2max)/w)))*dt + s2*dw2)
  m$addObs(y ~ 10 - ws*log(1 + exp((10 - z2 - h20 - y0)/ws)))
  m$setVariance(y ~ r)
  m$addInput(u)
  m$setParameter(
    k1 = c(initial = 0.05, lower = 1e-4, upper = 1),
    a1 = c(initial = 0.5, lower = 0.1, upper = 3),
    k3 = c(initial = 0.05, lower = 1e-4, upper = 1),
    a2 = c(initial = 0.5, lower = 0.02, upper = 3),
    k4 = c(initial = 0.05, lower = 1e-4, upper = 1),
    kx = c(initial = 0.5, lower = 0, upper = 1),
    h1max = c(initial = 10, lower = 1, upper = 100),
    h2max = c(initial = 10, lower = 1, upper = 40),
    y0 = c(initial = 0, lower = -20, upper = 8),
    w = 0.1, ws = 0.05, s1 = 1e-4, s2 = 1e-4,
    r = c(initial = 0.01, lower = 1e-8, upper = 1),
    h10 = c(initial = 5, lower = 0.1, upper = 100),
    h20 = c(initial = 5, lower = 0.1, upper = 40))
  m$setInitialState(list(mean = c(0, 0), cov = 4e-8 * diag(2)))
  m
}

if (mode == "loglik") {
  n <- as.integer(args[2]); fast <- args[3] == "1"; file <- args[4]
  substeps <- as.integer(args[5])
  repeats <- if (length(args) >= 6) as.integer(args[6]) else 21
  data <- read.csv(file, comment.char = "#")
  if (length(args) >= 7) data <- data[seq_len(as.integer(args[7])), ]
  delta <- data$t[2] - data$t[1]
  t0 <- Sys.time()
  m <- tank_chain(n, fast)
  nll <- m$likelihood(data, method = "ekf", ode.timestep = delta / substeps, silent = TRUE)
  setup <- secs(t0)
  tape <- m$getTimers()["Constructing AD Fun", "elapsed"]
  par <- nll$par
  value <- nll$fn(par)
  fn_s <- median_time(nll$fn, par, repeats)
  gr_s <- median_time(nll$gr, par, max(3, repeats %/% 4))  # value and gradient at a new x
  json_line(list(tool = "ctsmTMB", model = sprintf("tanks%d%s", n, if (fast) "+sensor" else ""),
                 substeps = substeps, n = nrow(data), setup_s = setup, tape_s = tape,
                 fn_s = fn_s, ns_per_sample = 1e9 * fn_s / nrow(data), gr_s = gr_s,
                 n_par = length(par), loglik = -value))
} else if (mode == "tanks") {
  file <- args[2]
  substeps <- if (length(args) >= 3) as.integer(args[3]) else 1
  data <- read.csv(file, comment.char = "#")[, c("t", "u", "y")]
  delta <- data$t[2] - data$t[1]
  t0 <- Sys.time()
  m <- tanks_model()
  fit <- m$estimate(data, method = "ekf", ode.timestep = delta / substeps, silent = TRUE,
                    control = list(trace = 0, iter.max = 1e5, eval.max = 1e5))
  wall <- secs(t0)
  timers <- m$getTimers()
  opt <- m$getPrivate()$results$opt
  out <- list(tool = "ctsmTMB", substeps = substeps, wall_s = wall,
              tape_s = timers["Constructing AD Fun", "elapsed"],
              nlminb_s = timers["Estimation", "elapsed"],
              loglik = if (is.null(fit)) NA else -fit$nll,
              iterations = if (is.null(opt)) NA else opt$iterations,
              evaluations_fn = if (is.null(opt)) NA else opt$evaluations[["function"]],
              evaluations_gr = if (is.null(opt)) NA else opt$evaluations[["gradient"]],
              convergence = if (is.null(opt)) NA else opt$convergence,
              message = if (is.null(opt)) "failed" else opt$message)
  if (!is.null(fit)) for (p in names(fit$par.fixed)) out[[p]] <- fit$par.fixed[[p]]
  if (length(args) >= 4) {  # log L at the given parameter values, same tape
    at <- read.table(args[4], col.names = c("name", "value"), stringsAsFactors = FALSE)
    nll <- m$getPrivate()$nll
    x <- nll$par
    x[at$name[at$name %in% names(x)]] <- at$value[at$name %in% names(x)]
    out$loglik_at_given <- -nll$fn(x)
  }
  json_line(out)
} else if (mode == "tanks-loglik") {
  data <- read.csv(args[2], comment.char = "#")[, c("t", "u", "y")]
  substeps <- as.integer(args[3])
  at <- read.table(args[4], col.names = c("name", "value"), stringsAsFactors = FALSE)
  m <- tanks_model()
  nll <- m$likelihood(data, method = "ekf", ode.timestep = (data$t[2] - data$t[1]) / substeps,
                      silent = TRUE)
  x <- nll$par
  x[at$name[at$name %in% names(x)]] <- at$value[at$name %in% names(x)]
  json_line(list(tool = "ctsmTMB", substeps = substeps, loglik_start = -nll$fn(nll$par),
                 loglik_at_given = -nll$fn(x)))
} else if (mode == "ou") {
  substeps <- as.integer(args[2])
  m <- ctsmTMB$new()
  m$addSystem(dx ~ -theta*x*dt + sigma*dw1)
  m$addObs(y ~ x)
  m$setVariance(y ~ r)
  m$setParameter(theta = c(initial = 1, lower = 0.01, upper = 10),
                 sigma = c(initial = 0.5, lower = 0.001, upper = 5), r = 0.01)
  m$setInitialState(list(mean = 0, cov = matrix(0.125)))
  for (file in args[-(1:2)]) {
    data <- read.csv(file, comment.char = "#")[, c("t", "y")]
    delta <- data$t[2] - data$t[1]
    t0 <- Sys.time()
    fit <- m$estimate(data, method = "ekf", ode.timestep = delta / substeps, silent = TRUE,
                      control = list(trace = 0, iter.max = 1e5, eval.max = 1e5))
    opt <- m$getPrivate()$results$opt
    json_line(list(tool = "ctsmTMB", substeps = substeps, file = basename(file), wall_s = secs(t0),
                   theta = fit$par.fixed[["theta"]], sigma = fit$par.fixed[["sigma"]],
                   loglik = -fit$nll, convergence = opt$convergence))
  }
} else {
  stop("usage: Rscript bench/ekf_ctsmtmb.R loglik|tanks|ou ... (see the header)")
}
