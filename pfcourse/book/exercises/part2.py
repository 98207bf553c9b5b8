"""Checkers of Part II (the robot and terrain navigation: chapters 10-16)."""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field

import numpy as np
from scipy import special, stats

from pfcourse.book.exercises.checking import CheckReport, _answer, _cloud_answers, _settled, _shaped
from pfcourse.seeding import run_filter_seed


# ----------------------------------------------------------------------------- chapter 12
#: Cases of :func:`check_pose_density`: (reading ``(r, b)``, landmark ``l``, standard deviations
#: ``(s_r, s_b)``): a far reading, a short one (where the truncation to ``r' > 0`` matters) and one
#: at a bearing near ``pi`` (where the bearing residual must be wrapped).
POSE_DENSITY_CASES = (
    (np.array([12.0, 0.7]), np.array([3.0, -4.0]), np.array([0.7, 0.025])),
    (np.array([0.9, -2.0]), np.array([-10.0, 5.0]), np.array([0.7, 0.05])),
    (np.array([20.0, 3.1]), np.array([0.0, 0.0]), np.array([0.7, 0.025])),
)


POSE_DENSITY_MISTAKES = {
    "bearing_added": "it predicts the bearing as atan2(l - p) + theta; the landmark is seen at its direction "
                     "minus the heading, h_b(x) = wrap(atan2(l_y - p_y, l_x - p_x) - theta)",
    "no_jacobian": "it misses the Jacobian term -log h_r(x): the ring of radius r' has circumference 2 pi r', so the "
                   "density of the position is the polar one divided by the radius",
    "no_direction": "it misses the direction's density 1 / (2 pi): the direction phi of the robot seen from the "
                    "landmark is drawn uniformly, the reading says nothing about it",
    "no_truncation": "it misses the truncation term -log Phi(r / s_r): the range r' is drawn positive only, so its "
                     "normal density is divided by P(r' > 0) = Phi(r / s_r)",
    "unwrapped": "it does not wrap the bearing residual b - h_b(x) into (-pi, pi]: near a bearing of pi a pose that "
                 "fits the reading gets a residual of almost 2 pi",
    "variance_for_sd": "it uses s_r and s_b as variances; they are the standard deviations of the range and bearing "
                       "noise",
}


def _wrap(angle: np.ndarray) -> np.ndarray:
    return (np.asarray(angle) + np.pi) % (2.0 * np.pi) - np.pi


def pose_reading_log_density(x: np.ndarray, z: np.ndarray, landmark: np.ndarray, sd: np.ndarray,
                             mistake: str | None = None) -> np.ndarray:
    """``log q_z(x)`` of the pose drawn from a range-bearing reading (chapter 12, Algorithm 12.1):

        q_z(x) = N(h_r(x); r, s_r^2) N(wrap(b - h_b(x)); 0, s_b^2) / (Phi(r / s_r) 2 pi h_r(x)),

    ``h_r(x) = |l - p|``, ``h_b(x) = wrap(atan2(l_y - p_y, l_x - p_x) - theta)`` for each pose
    ``x = (p_x, p_y, theta)`` (rows), ``z = (r, b)``, ``sd = (s_r, s_b)``. ``mistake`` (a key of
    :data:`POSE_DENSITY_MISTAKES`) computes that mistake instead."""
    x = np.asarray(x, dtype=float)
    r, b = (float(v) for v in z)
    s_r, s_b = (float(v) ** 2 if mistake == "variance_for_sd" else float(v) for v in sd)
    dx, dy = landmark[0] - x[:, 0], landmark[1] - x[:, 1]
    h_r = np.hypot(dx, dy)
    h_b = np.arctan2(dy, dx) + (x[:, 2] if mistake == "bearing_added" else -x[:, 2])
    nu_b = (b - h_b) if mistake == "unwrapped" else _wrap(b - _wrap(h_b))
    log_q = (-np.log(2 * np.pi * s_r * s_b) - 0.5 * (((r - h_r) / s_r) ** 2 + (nu_b / s_b) ** 2))
    if mistake != "no_truncation":
        log_q -= stats.norm.logcdf(r / s_r)
    if mistake != "no_direction":
        log_q -= np.log(2 * np.pi)
    if mistake != "no_jacobian":
        log_q -= np.log(h_r)
    return log_q


def _poses_near_reading(z: np.ndarray, landmark: np.ndarray, sd: np.ndarray, n: int,
                        rng: np.random.Generator) -> np.ndarray:
    """``n`` poses near the ring of the reading (twice its noise), where the density is worth checking."""
    ranges = np.abs(z[0] + 2 * sd[0] * rng.standard_normal(n))
    phi = rng.uniform(-np.pi, np.pi, n)
    theta = _wrap(phi + np.pi - (z[1] + 2 * sd[1] * rng.standard_normal(n)))
    return np.column_stack([landmark[0] + ranges * np.cos(phi), landmark[1] + ranges * np.sin(phi), theta])


def check_pose_density(fn: Callable, n_poses: int = 40, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(x, z, landmark, sd) -> (N,)``: ``log q_z(x)`` of poses ``x`` (N, 3) for a
    reading ``z = (r, b)`` of the landmark at ``landmark`` with noise standard deviations ``sd = (s_r, s_b)``.

    Each case of :data:`POSE_DENSITY_CASES` must equal :func:`pose_reading_log_density` to ``rtol``;
    an answer that does not is compared with each mistake of :data:`POSE_DENSITY_MISTAKES`, and the
    report names the one that fits.
    """
    report = CheckReport("pose density")
    rng = np.random.default_rng(seed)
    cases = [(z, l, sd, _poses_near_reading(z, l, sd, n_poses, rng)) for z, l, sd in POSE_DENSITY_CASES]
    answers = []
    for z, l, sd, x in cases:
        answer = _answer(report, lambda: fn(x.copy(), z.copy(), l.copy(), sd.copy()), "fn(x, z, landmark, sd)",
                         "compute and return log q_z(x), one value per pose")
        if answer is None:
            return report
        answers.append(np.asarray(answer, dtype=float))
    wrong_shapes = [a.shape for a in answers if a.shape != (n_poses,)]
    if wrong_shapes:
        report.problems.append(f"the answer has shape {wrong_shapes[0]}, not ({n_poses},): return one log-density "
                               "per pose (a row of x)")
        return report
    if not all(np.isfinite(a).all() for a in answers):
        report.problems.append("some log-densities are NaN or infinite: every pose near the ring has a positive "
                               "density; compute it in the log domain")
        return report
    # the exact density first, then each mistake: the first that every case matches names the answer
    candidates = (None, *POSE_DENSITY_MISTAKES)
    matched = next((m for m in candidates if all(
        np.allclose(a, pose_reading_log_density(x, z, l, sd, m), rtol=rtol, atol=1e-9)
        for a, (z, l, sd, x) in zip(answers, cases))), "none")
    if matched is None:
        return report
    if matched != "none":
        report.problems.append(f"your function computes a known mistake: {POSE_DENSITY_MISTAKES[matched]}")
        return report
    case = next(c for c, (a, (z, l, sd, x)) in enumerate(zip(answers, cases))
                if not np.allclose(a, pose_reading_log_density(x, z, l, sd), rtol=rtol, atol=1e-9))
    report.problems.append(f"for the reading z = {cases[case][0]} the values differ from log q_z(x): check the two "
                           "Gaussian terms of the range and the wrapped bearing, and the terms -log Phi(r / s_r), "
                           "-log 2 pi and -log h_r(x)")
    return report

#: Chapter 11's exercise: a pose drawn from a bearing-only reading. The landmark, the bearing (rad), its
#: standard deviation (rad) and the radius (m) of the disc around the landmark the robot is known to be in.
BEARING_POSE_CASE = dict(landmark=np.array([10.0, -20.0]), b=0.8, sd_b=0.05, r_max=40.0)
#: The typical mistakes of the bearing-only draw, and why each is wrong (compared by a large cloud's statistics).
BEARING_POSE_MISTAKES = {
    "uniform_range": ("your positions crowd the landmark: a range drawn uniformly on [0, r_max] is not a position "
                      "uniform on the disc, whose range has density 2r / r_max^2: draw r = r_max sqrt(u)"),
    "half_circle": ("your positions cover only half of the disc: the reading says nothing about the side of the "
                    "landmark the robot is on, so the direction phi is uniform on (-pi, pi]"),
    "no_pi": ("your robots face away from the landmark: seen from p = l + r (cos phi, sin phi) the landmark lies "
              "in direction phi + pi, so theta = wrap(phi + pi - b')"),
    "bearing_sign": ("your headings add the bearing: the landmark appears at bearing b' = (phi + pi) - theta, "
                     "so theta = wrap(phi + pi - b'), not phi + pi + b'"),
    "sd_as_variance": ("your bearings are too precise: sd_b is a standard deviation, b' = b + sd_b * e, not "
                       "b + sd_b**2 * e"),
}


def bearing_pose_draw(b: float, landmark: np.ndarray, sd_b: float, r_max: float, n: int, rng: np.random.Generator,
                      mistake: str | None = None) -> np.ndarray:
    """``n`` poses ``(x, y, theta)`` drawn given a bearing-only reading ``b`` of ``landmark``: a position uniform
    on the disc of radius ``r_max`` around it (``r = r_max sqrt(u)``, ``phi ~ U(-pi, pi)``), a bearing
    ``b' ~ N(b, sd_b^2)`` and the heading ``theta = wrap(phi + pi - b')`` that makes the landmark appear at
    ``b'``. ``mistake`` (a key of :data:`BEARING_POSE_MISTAKES`) computes that mistake instead."""
    u = rng.random(n)
    r = r_max * (u if mistake == "uniform_range" else np.sqrt(u))
    phi = rng.uniform(0.0, np.pi, n) if mistake == "half_circle" else rng.uniform(-np.pi, np.pi, n)
    sd = sd_b ** 2 if mistake == "sd_as_variance" else sd_b
    b_drawn = b + sd * rng.standard_normal(n)
    shift = 0.0 if mistake == "no_pi" else np.pi
    theta = phi + shift + b_drawn if mistake == "bearing_sign" else phi + shift - b_drawn
    return np.column_stack([landmark[0] + r * np.cos(phi), landmark[1] + r * np.sin(phi), _wrap(theta)])


def _bearing_pose_features(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Means and sds of (range / r_max, cos phi, sin phi, bearing residual) of drawn poses."""
    case = BEARING_POSE_CASE
    d = x[:, :2] - case["landmark"]
    phi = np.arctan2(d[:, 1], d[:, 0])
    residual = _wrap(case["b"] - _wrap(phi + np.pi - x[:, 2]))
    f = np.column_stack([np.hypot(d[:, 0], d[:, 1]) / case["r_max"], np.cos(phi), np.sin(phi), residual])
    return f.mean(axis=0), f.std(axis=0)


def check_bearing_pose_draw(fn: Callable, n: int = 100_000, seed: int = 0) -> CheckReport:
    """Check ``fn(b, landmark, sd_b, r_max, n, rng) -> (n, 3)``, leaving NumPy's global state as it was
    (:func:`_check_bearing_pose_draw`)."""
    saved = np.random.get_state()
    try:
        return _check_bearing_pose_draw(fn, n, seed)
    finally:
        np.random.set_state(saved)


def _check_bearing_pose_draw(fn: Callable, n: int, seed: int) -> CheckReport:
    """In turn: shape and finiteness; headings in (-pi, pi]; positions within ``r_max`` of the landmark; the
    generator (:func:`~pfcourse.book.exercises.part1._generator_problem`); then the means and standard deviations of
    (range / r_max, cos phi, sin phi, bearing residual) against 4n reference draws, every difference within
    6 standard errors (doubled for the standard deviations). A failure is compared with each mistake of
    :data:`BEARING_POSE_MISTAKES`, so that it is named."""
    from pfcourse.book.exercises.part1 import _generator_problem

    case = BEARING_POSE_CASE
    report = CheckReport("pose from a bearing-only reading")

    def call(k, rng):
        return fn(case["b"], case["landmark"].copy(), case["sd_b"], case["r_max"], k, rng)

    answer = _answer(report, lambda: call(n, np.random.default_rng(seed)), "fn(b, landmark, sd_b, r_max, n, rng)",
                     "return the n drawn poses, one (x, y, theta) per row")
    if answer is None or not _shaped(report, answer, (n, 3), "n poses, one (x, y, theta) per row"):
        return report
    answer = np.asarray(answer, dtype=float)
    if not np.isfinite(answer).all():
        report.problems.append("the poses hold NaN or infinity")
        return report
    if np.any(np.abs(answer[:, 2]) > np.pi + 1e-9):
        report.problems.append("some headings lie outside (-pi, pi]: wrap theta")
        return report
    if np.any(np.hypot(*(answer[:, :2] - case["landmark"]).T) > case["r_max"] * (1 + 1e-9)):
        report.problems.append("some positions lie farther than r_max from the landmark: the robot is known to be "
                               "within r_max of it, so the range is at most r_max")
        return report
    problem = _generator_problem(lambda rng: call(200, rng), lambda a, b: np.array_equal(np.asarray(a), np.asarray(b)),
                                 what="pose")
    if problem:
        report.problems.append(problem)
        return report
    mean, sd = _bearing_pose_features(answer)

    def fits(mistake: str | None) -> bool:
        ref = bearing_pose_draw(case["b"], case["landmark"], case["sd_b"], case["r_max"], 4 * n,
                                np.random.default_rng(10_000), mistake=mistake)
        ref_mean, ref_sd = _bearing_pose_features(ref)
        se_mean = np.sqrt(sd**2 / n + ref_sd**2 / (4 * n)) + 1e-12
        se_sd = ref_sd * np.sqrt(1 / (2 * n) + 1 / (8 * n)) * 2 + 1e-12
        return max(np.max(np.abs(mean - ref_mean) / se_mean), np.max(np.abs(sd - ref_sd) / se_sd)) <= 6

    if not _settled(report, fits, BEARING_POSE_MISTAKES):
        report.problems.append("the poses' spread differs from the model's: a position uniform on the disc, a "
                               "direction uniform on the circle, b' = b + sd_b e and theta = wrap(phi + pi - b')")
    return report


#: A small DEM for :func:`check_robust_altimeter`: 7 rows (north) by 9 columns (east), cells of
#: 80 m east-west and 100 m north-south (unequal, and a non-square grid, so swapped axes show).
ALTIMETER_HEIGHTS = 300.0 + 60.0 * np.sin(np.arange(7)[:, None] * 0.9) * np.cos(np.arange(9)[None, :] * 0.7) \
    + 25.0 * np.arange(9)[None, :]


ALTIMETER_DX, ALTIMETER_DY, ALTIMETER_RF = 80.0, 100.0, 20.0**2


#: mistake -> the sentence that names it (:func:`altimeter_log_likelihood`'s ``mistake``).
ALTIMETER_MISTAKES = {
    "swapped": "x indexes the columns of the map (j = x / dx) and y its rows (i = y / dy), not the other way round",
    "nearest": "the height is read at the nearest node: interpolate bilinearly between the four corners of the cell",
    "rf_as_sd": "Rf is the variance of the altimeter's noise, so the standard deviation is sqrt(Rf)",
    "sign": "the altimeter reads the height above the ground, z - h(x, y), not h(x, y) - z",
    "no_constant": "the Gaussian log-density has the term -(1/2) log(2 pi Rf), which your values lack",
}


def altimeter_log_likelihood(particles: np.ndarray, y: float, heights: np.ndarray, dx: float, dy: float,
                             rf: float, mistake: str | None = None) -> np.ndarray:
    """``log N(y; z - h(x, y), Rf)`` of each particle ``(x, y, z, psi)``, ``h`` bilinear on ``heights[i, j]``
    at ``(j dx, i dy)``; ``-inf`` outside ``[0, (nx-1) dx] x [0, (ny-1) dy]``. With a ``mistake`` of
    :data:`ALTIMETER_MISTAKES`, what that mistake computes (for the checker)."""
    p = np.asarray(particles, dtype=float)
    h = np.asarray(heights, dtype=float)
    if mistake == "swapped":
        h, dx, dy = h.T, dy, dx
    if mistake == "dx_for_dy":
        dy = dx
    if mistake == "north_up":  # row 0 taken for the northern edge, as in the DEM file
        h = h[::-1]
    ny, nx = h.shape
    col, row = p[:, 0] / dx, p[:, 1] / dy
    inside = (col >= 0) & (col <= nx - 1) & (row >= 0) & (row <= ny - 1)
    j = np.clip(np.floor(col), 0, nx - 2).astype(int)
    i = np.clip(np.floor(row), 0, ny - 2).astype(int)
    s, t = np.clip(col - j, 0, 1), np.clip(row - i, 0, 1)
    if mistake == "nearest":
        s, t = np.round(s), np.round(t)
    # corners_swapped: h10 read north of the node and h01 east of it
    east, north = (h[i + 1, j], h[i, j + 1]) if mistake == "corners_swapped" else (h[i, j + 1], h[i + 1, j])
    ground = (1 - s) * (1 - t) * h[i, j] + s * (1 - t) * east + (1 - s) * t * north + s * t * h[i + 1, j + 1]
    predicted = ground - p[:, 2] if mistake == "sign" else p[:, 2] - ground
    var = rf**2 if mistake == "rf_as_sd" else rf
    out = -0.5 * (y - predicted) ** 2 / var - (0.0 if mistake == "no_constant" else 0.5 * np.log(2 * np.pi * var))
    return np.where(inside, out, -np.inf)


#: The junk-reading altimeter of :func:`check_robust_altimeter` (chapter 17, exercise 17.4): with
#: probability ``eps`` a reading is uniform on ``[0, y_max]``.
ROBUST_EPS, ROBUST_Y_MAX = 0.05, 3000.0


#: mistake -> the sentence that names it (:func:`robust_altimeter_log_likelihood`'s ``mistake``).
ROBUST_ALTIMETER_MISTAKES = {
    "swapped": ALTIMETER_MISTAKES["swapped"],
    "nearest": ALTIMETER_MISTAKES["nearest"],
    "rf_as_sd": ALTIMETER_MISTAKES["rf_as_sd"],
    "sign": ALTIMETER_MISTAKES["sign"],
    "corners_swapped": "the corners h10 and h01 are exchanged: h10 is the node east of (i, j), heights[i, j+1] "
                       "(weight s(1 - t), s the fraction in x), and h01 the node north of it, heights[i+1, j]",
    "dx_for_dy": "it divides y by dx: the cells are not square, so the row is i = y / dy and the column j = x / dx",
    "no_constant": "the Gaussian's -(1/2) log(2 pi Rf) is missing: in a mixture it no longer cancels, since it sets "
                   "how the Gaussian term weighs against the uniform one",
    "mixed_logs": "it mixes the logarithms, (1 - eps) log N + eps log(1 / y_max); the likelihood is the mixture of "
                  "the densities, so take the log of (1 - eps) N + eps / y_max (np.logaddexp)",
    "no_range": "the junk term is eps, not eps / y_max: a reading uniform on [0, y_max] has density 1 / y_max",
    "no_gaussian_share": "the Gaussian term lacks its probability 1 - eps: the two terms' probabilities must add "
                         "up to one",
    "gaussian_only": "it ignores the junk readings: a reading far from z - h must keep the likelihood eps / y_max "
                     "rather than fall to almost zero",
    "north_up": "it reads the map with row 0 as the northern edge (heights[::-1], the DEM file's own order): here "
                "row 0 is the southern edge, so row i lies i dy north of it",
    "max_of_terms": "it keeps the larger of the two terms (np.maximum); the mixture adds them, so take "
                    "np.logaddexp of their logarithms",
    "no_probabilities": "the mixture lacks its probabilities, log(N + 1 / y_max): weigh the Gaussian by 1 - eps and "
                        "the junk density by eps",
    "product_of_terms": "it multiplies the two terms (adds their logarithms); a mixture is their sum, "
                        "log((1 - eps) N + eps / y_max)",
}


def robust_altimeter_log_likelihood(particles: np.ndarray, y: float, heights: np.ndarray, dx: float, dy: float,
                                    rf: float, eps: float, y_max: float, mistake: str | None = None) -> np.ndarray:
    """``log((1 - eps) N(y; z - h(x, y), Rf) + eps / y_max)`` per particle, ``-inf`` off the map (the bilinear
    ``h`` of :func:`altimeter_log_likelihood`). With a ``mistake`` of :data:`ROBUST_ALTIMETER_MISTAKES`, what
    that mistake computes (for the checker)."""
    gauss_mistake = mistake if mistake in ("swapped", "nearest", "rf_as_sd", "sign", "no_constant", "corners_swapped",
                                           "dx_for_dy", "north_up") else None
    log_gauss = altimeter_log_likelihood(particles, y, heights, dx, dy, rf, gauss_mistake)
    inside = np.isfinite(log_gauss)
    g = np.where(inside, log_gauss, 0.0)
    junk = np.log(eps if mistake == "no_range" else eps / y_max)
    gauss = np.log1p(-eps) + g
    if mistake == "max_of_terms":
        out = np.maximum(gauss, junk)
    elif mistake == "no_probabilities":
        out = np.logaddexp(g, -np.log(y_max))
    elif mistake == "product_of_terms":
        out = gauss + junk
    elif mistake == "mixed_logs":
        out = (1 - eps) * g + eps * np.log(1.0 / y_max)
    elif mistake == "gaussian_only":
        out = g
    else:
        out = np.logaddexp((0.0 if mistake == "no_gaussian_share" else np.log1p(-eps)) + g, junk)
    return np.where(inside, out, -np.inf)


def check_robust_altimeter(fn: Callable, seed: int = 0) -> CheckReport:
    """Check ``fn(particles, y, heights, dx, dy, rf, eps, y_max) -> (N,)``, the log-likelihood of an altimeter
    whose reading is junk (uniform on ``[0, y_max]``) with probability ``eps``.

    Compared with :func:`robust_altimeter_log_likelihood` to round-off on particles drawn over the test map
    :data:`ALTIMETER_HEIGHTS` (a few of them off it, and altitudes spread so that both terms of the mixture
    dominate somewhere); a wrong answer is compared with each mistake of :data:`ROBUST_ALTIMETER_MISTAKES` and
    the one that fits is named.
    """
    report = CheckReport("altimeter with junk readings")
    rng = np.random.default_rng(seed)
    ny, nx = ALTIMETER_HEIGHTS.shape
    n = 300
    particles = np.column_stack([rng.uniform(-40, (nx - 1) * ALTIMETER_DX + 40, n),
                                 rng.uniform(-40, (ny - 1) * ALTIMETER_DY + 40, n),
                                 rng.normal(1000.0, 80.0, n), rng.uniform(-np.pi, np.pi, n)])
    y = 600.0
    args = (y, ALTIMETER_HEIGHTS, ALTIMETER_DX, ALTIMETER_DY, ALTIMETER_RF, ROBUST_EPS, ROBUST_Y_MAX)
    answer = _answer(report, lambda: fn(particles.copy(), y, ALTIMETER_HEIGHTS.copy(), *args[2:]),
                     "fn(particles, y, heights, dx, dy, rf, eps, y_max)", "return one log-likelihood per particle")
    if answer is None or not _shaped(report, answer, (n,), "one log-likelihood per particle (a row of particles)"):
        return report
    answer = np.asarray(answer, dtype=float)
    exact = robust_altimeter_log_likelihood(particles, *args)
    off = ~np.isfinite(exact)

    def fits(mistake: str | None) -> bool:
        values = robust_altimeter_log_likelihood(particles, *args, mistake=mistake)
        gone = ~np.isfinite(values)
        return (np.array_equal(gone, answer == -np.inf)
                and np.allclose(answer[~gone], values[~gone], rtol=1e-9, atol=1e-9))

    if _settled(report, fits, ROBUST_ALTIMETER_MISTAKES):
        return report
    if not np.all(answer[off] == -np.inf):
        report.problems.append("a particle off the map must get log-likelihood -inf (likelihood zero: there is no "
                               "terrain under it), not a number or NaN")
        return report
    with np.errstate(invalid="ignore"):
        gap = np.where(off, -np.inf, np.abs(np.where(off, 0.0, answer) - np.where(off, 0.0, exact)))
    k = int(np.argmax(np.nan_to_num(gap, nan=np.inf)))
    report.problems.append(f"particle {k} at ({particles[k, 0]:.0f}, {particles[k, 1]:.0f}) m gets {answer[k]:.4f}, "
                           f"not {exact[k]:.4f}: check the bilinear height and log((1 - eps) N(y; z - h, Rf) + "
                           "eps / y_max)")
    return report


#: The cloud of :func:`check_epanechnikov_move`: N particles in d = 3 dimensions, correlated and of
#: unequal scales (so that a move with S instead of S^{1/2}, or with the identity, shows).
JITTER_N = 20_000


JITTER_SCALE = 0.5


JITTER_COV = np.array([[400.0**2, 0.6 * 400.0 * 50.0, 0.0], [0.6 * 400.0 * 50.0, 50.0**2, 0.0], [0.0, 0.0, 0.2**2]])


#: mistake -> the sentence that names it (:func:`epanechnikov_move`'s ``mistake``), for
#: :func:`check_epanechnikov_move`.
EPANECHNIKOV_MISTAKES = {
    "gaussian": "it draws eps from a Gaussian, whose moves reach beyond the kernel's support; the Epanechnikov "
                "kernel is zero outside the unit ball, so every whitened move is shorter than h",
    "gaussian_bandwidth": "it uses the Gaussian kernel's bandwidth (4 / (d + 2))^(1/(d+4)) N^(-1/(d+4)); the "
                          "Epanechnikov kernel's is A N^(-1/(d+4)) with A = (8 (d + 4) (2 sqrt(pi))^d / c_d)^(1/(d+4))",
    "uniform_radius": "it draws the radius |eps| uniformly on [0, 1]; a ball holds more volume far from its centre, "
                      "so the radius has density proportional to r^(d-1) (1 - r^2)",
    "uniform_ball": "it draws eps uniformly in the unit ball (radius U^(1/d)), the flat kernel; the Epanechnikov "
                    "kernel weighs each point by 1 - |eps|^2, so the radius is sqrt of a Beta(d/2, 2) draw",
    "squared_radius": "it takes the Beta(d/2, 2) draw itself as the radius; that draw is |eps|^2, so the radius is "
                      "its square root",
    "product": "it draws each coordinate from the one-dimensional Epanechnikov kernel; their product is a "
               "different kernel on the cube, while the optimal one is 1 - |eps|^2 on the unit ball",
    "covariance_for_root": "it scales eps by the covariance S itself; the kernel's spread must follow a square "
                           "root A of S (A A^T = S, Cholesky or eigen), or the moves have covariance h^2 S^2 / (d + 4)",
}


def epanechnikov_bandwidth(n: int, d: int) -> float:
    """Musso, Oudjane and Le Gland's optimal bandwidth for the Epanechnikov kernel: ``A N^{-1/(d+4)}``."""
    c_d = np.pi ** (d / 2) / special.gamma(d / 2 + 1)  # the volume of the unit ball
    return (8.0 / c_d * (d + 4) * (2.0 * np.sqrt(np.pi)) ** d) ** (1.0 / (d + 4)) * n ** (-1.0 / (d + 4))


def epanechnikov_move(particles: np.ndarray, scale: float, rng: np.random.Generator,
                      mistake: str | None = None) -> np.ndarray:
    """``x^i + h A eps^i``: ``eps^i`` drawn from the Epanechnikov kernel on the unit ball (a direction
    ``g / |g|``, ``g ~ N(0, I_d)``, times a radius ``sqrt(Beta(d/2, 2))``), ``A`` the Cholesky factor of the
    cloud's covariance, ``h = scale * epanechnikov_bandwidth(N, d)``. With a ``mistake`` of
    :data:`EPANECHNIKOV_MISTAKES`, what that mistake computes (for the checker)."""
    x = np.asarray(particles, dtype=float)
    n, d = x.shape
    if mistake == "gaussian_bandwidth":
        h = scale * (4.0 / (d + 2)) ** (1.0 / (d + 4)) * n ** (-1.0 / (d + 4))
    else:
        h = scale * epanechnikov_bandwidth(n, d)
    g = rng.standard_normal((n, d))
    direction = g / np.linalg.norm(g, axis=1, keepdims=True)
    if mistake == "gaussian":
        eps = g
    elif mistake == "product":
        u = rng.uniform(-1.0, 1.0, (n, d, 3))
        eps = np.median(u, axis=2)  # the median of three uniforms has the 1-D Epanechnikov density
    else:
        radius = {"uniform_radius": lambda: rng.random(n), "uniform_ball": lambda: rng.random(n) ** (1.0 / d),
                  "squared_radius": lambda: rng.beta(d / 2, 2.0, n)}.get(mistake, lambda: np.sqrt(rng.beta(d / 2, 2.0, n)))()
        eps = direction * radius[:, None]
    S = np.cov(x, rowvar=False)
    A = S if mistake == "covariance_for_root" else np.linalg.cholesky(S)
    return x + h * eps @ A.T


def check_epanechnikov_move(fn: Callable, seed: int = 0) -> CheckReport:
    """Check ``fn(particles, scale, rng) -> moved``, the regularised filter's move with the Epanechnikov kernel.

    ``x^i <- x^i + h A eps^i`` with ``A A^T = S`` the cloud's covariance, ``eps^i`` drawn independently
    from ``K(eps) = (d + 2) / (2 c_d) (1 - |eps|^2)`` on the unit ball and ``h = scale *``
    :func:`epanechnikov_bandwidth`. The moves of a cloud of :data:`JITTER_N` correlated particles,
    whitened (``L^{-1} D / h``, ``L`` the Cholesky factor of ``S``; the kernel is round, so any square root
    gives the same law), must have squared lengths following ``Beta(d/2, 2)`` (Kolmogorov-Smirnov,
    p > 1e-4), mean zero (six standard errors) and covariance ``I / (d + 4)`` (each entry within a tenth of
    ``1 / (d + 4)``). The draws must come from ``rng`` (the generator check); a wrong answer is compared
    with each mistake of :data:`EPANECHNIKOV_MISTAKES` (the same statistics against 4N draws of that
    mistake) and the one that fits is named.
    """
    from pfcourse.book.exercises.part1 import _generator_problem

    report = CheckReport("Epanechnikov kernel move")
    rng = np.random.default_rng(seed)
    n, d = JITTER_N, JITTER_COV.shape[0]
    particles = rng.multivariate_normal([1000.0, -200.0, 1.0], JITTER_COV, n)
    saved = np.random.get_state()
    try:
        answer = _answer(report, lambda: fn(particles.copy(), JITTER_SCALE,
                                            np.random.default_rng(run_filter_seed(seed))),
                         "fn(particles, scale, rng)", "return the moved particles, an array like particles")
    finally:
        np.random.set_state(saved)
    if answer is None or not _shaped(report, answer, particles.shape, "every particle, moved (an array like "
                                                                      "particles)"):
        return report
    moved = np.asarray(answer, dtype=float)
    if not np.isfinite(moved).all():
        report.problems.append("the moved particles hold NaN or infinity")
        return report
    problem = _generator_problem(lambda r: fn(particles[:200].copy(), JITTER_SCALE, r),
                                 lambda a, b: np.array_equal(np.asarray(a), np.asarray(b)), what="move")
    if problem:
        report.problems.append(problem)
        return report
    h = JITTER_SCALE * epanechnikov_bandwidth(n, d)
    L = np.linalg.cholesky(np.cov(particles, rowvar=False))

    def whitened(cloud: np.ndarray) -> np.ndarray:
        return np.linalg.solve(L, (cloud - particles[: len(cloud)]).T).T / h

    white = whitened(moved)
    C = np.cov(white, rowvar=False)
    if np.all(np.abs(C) < 1e-12):
        report.problems.append("every particle moves by the same amount (or not at all): draw one independent "
                               "eps^i per particle, an (N, d) array")
        return report
    if np.max(np.abs(white.mean(axis=0)) / np.sqrt(np.diag(C))) > 6 / np.sqrt(n):
        report.problems.append("the moves do not average to zero: the kernel is centred on each particle, and "
                               "eps^i is a direction uniform on the sphere times a radius")
        return report
    squared = np.sum(white**2, axis=1)
    tolerance = 0.1 / (d + 4)

    def fits(mistake: str | None) -> bool:
        if mistake is None:
            law_fits = stats.kstest(squared, stats.beta(d / 2, 2.0).cdf).pvalue > 1e-4
            target = np.eye(d) / (d + 4)
        else:
            # 4N draws of the mistake, from generators of their own
            ref_white = np.vstack([whitened(epanechnikov_move(particles, JITTER_SCALE,
                                                              np.random.default_rng(10_000 + seed + k), mistake))
                                   for k in range(4)])
            law_fits = stats.ks_2samp(squared, np.sum(ref_white**2, axis=1)).pvalue > 1e-4
            target = np.cov(ref_white, rowvar=False)
        return law_fits and np.max(np.abs(C - target)) < max(tolerance, 0.1 * np.max(np.abs(target)))

    if _settled(report, fits, EPANECHNIKOV_MISTAKES):
        return report
    # the kernel's shape at another length: a wrong bandwidth (c_d taken as the sphere's area, say), not a wrong
    # radius law; E|eps|^2 = d / (d + 4) under the kernel
    stretch = float(np.sqrt(squared.mean() / (d / (d + 4))))
    if abs(stretch - 1) > 0.02 and stats.kstest(squared / stretch**2, stats.beta(d / 2, 2.0).cdf).pvalue > 1e-4:
        report.problems.append(f"the moves have the kernel's shape but {stretch:.2f} times its length: check the "
                               "bandwidth h = scale * A N^(-1/(d+4)), A = (8 (d + 4) (2 sqrt(pi))^d / c_d)^(1/(d+4)) "
                               "with c_d the volume of the unit ball, pi^(d/2) / Gamma(d/2 + 1)")
        return report
    if squared.max() > 1 + 1e-9:
        report.problems.append(f"some whitened moves are {np.sqrt(squared.max()):.2f} times h long: the "
                               "Epanechnikov kernel is zero outside the unit ball, so check eps, h = scale * A "
                               "N^(-1/(d+4)) and the square root of S")
    else:
        report.problems.append("the moves' lengths do not follow the kernel: |eps|^2 must follow Beta(d/2, 2) "
                               "(density proportional to r^(d-1) (1 - r^2) for the radius r) and the direction "
                               "must be uniform on the sphere")
    return report


# --- chapter 14: the likelihood-field log-weight of one scan for a cloud -------------------------------
#: The mistakes :func:`check_likelihood_field` names, each with its one-sentence reason.
FIELD_MISTAKES = {
    "max_range_kept": "beams at the maximum range z_max hit nothing and give no end point: leave them out of "
                      "the sum, as table 6.3 does",
    "no_heading": "a beam points along theta + a_b, the robot's heading plus the beam's angle, not along a_b alone",
    "no_rand": "the term z_rand / z_max is missing: without it an end point far from every wall makes the weight "
               "vanish, and one stray reading ruins a good pose",
    "no_constant": "the Gaussian density needs its factor 1 / (sqrt(2 pi) sigma): without it z_hit and z_rand "
                   "are mixed in the wrong proportion",
    "product": "the densities are multiplied and then logged: the product of hundreds of beams underflows to 0 "
               "(log 0 = -inf); add the logs instead",
}


def field_log_weights(poses: np.ndarray, z: np.ndarray, field, mistake: str | None = None) -> np.ndarray:
    """Table 6.3 in the log domain, ``sum_{b: z_b < z_max} log(z_hit N(d(e_b); 0, sigma^2) + z_rand / z_max)``
    (``field`` a :class:`pfcourse.scenarios.maprobot.LikelihoodField`), or one mistake of :data:`FIELD_MISTAKES`."""
    use = np.ones(len(z), dtype=bool) if mistake == "max_range_kept" else z < field.max_range
    heading = (0.0 if mistake == "no_heading" else poses[:, 2:3]) + field.angles[use]
    ends = np.stack([poses[:, 0:1] + z[use] * np.cos(heading), poses[:, 1:2] + z[use] * np.sin(heading)], axis=-1)
    d = field.grid.distance_at(ends)
    norm = 1.0 if mistake == "no_constant" else np.sqrt(2 * np.pi) * field.sigma
    dens = field.z_hit * np.exp(-0.5 * (d / field.sigma) ** 2) / norm
    if mistake != "no_rand":
        dens = dens + field.z_rand / field.max_range
    with np.errstate(divide="ignore"):
        return np.log(np.prod(dens, axis=1)) if mistake == "product" else np.log(dens).sum(axis=1)


class _RoomGrid:
    """A 6 m x 4 m room of 0.1 m cells with a wall stub, and ``distance_at`` as
    :class:`pfcourse.scenarios.maprobot.OccupancyGrid` has it (distance transform, ``inf`` off the map)."""

    resolution = 0.1

    def __init__(self) -> None:
        from scipy.ndimage import distance_transform_edt

        occ = np.zeros((40, 60), dtype=bool)
        occ[0, :] = occ[-1, :] = occ[:, 0] = occ[:, -1] = True
        occ[10:30, 30] = True
        self.occupied = occ
        self.distance = distance_transform_edt(~occ) * self.resolution

    def distance_at(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=float)
        j = np.floor(xy[..., 0] / self.resolution).astype(np.int64)
        i = np.floor(xy[..., 1] / self.resolution).astype(np.int64)
        inside = (i >= 0) & (i < self.occupied.shape[0]) & (j >= 0) & (j < self.occupied.shape[1])
        return np.where(inside, self.distance[np.where(inside, i, 0), np.where(inside, j, 0)], np.inf)


@dataclass(frozen=True)
class FieldCase:
    """What ``fn(poses, z, field)`` is given as ``field``: the grid and the likelihood field's parameters."""

    grid: _RoomGrid
    angles: np.ndarray
    max_range: float = 4.0
    z_hit: float = 0.9
    z_rand: float = 0.1
    sigma: float = 0.2


def check_likelihood_field(fn: Callable, n_particles: int = 40, seed: int = 0, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(poses, z, field) -> (N,)``: the likelihood-field log-weights of one scan ``z``
    (``(B,)``) for a cloud ``poses`` (``(N, 3)``) in a room, ``field`` a :class:`FieldCase` (its
    ``grid.distance_at``, ``angles``, ``max_range``, ``z_hit``, ``z_rand``, ``sigma``, as
    :class:`pfcourse.scenarios.maprobot.LikelihoodField` has them).  Two cases: a scan of 24 beams and one of 360
    (where a product of densities underflows), about a fifth of the beams at the maximum range.  An answer off
    :func:`field_log_weights` by more than ``rtol`` is compared with each mistake of :data:`FIELD_MISTAKES`."""
    report = CheckReport("likelihood field")
    grid = _RoomGrid()
    rng = np.random.default_rng(seed)
    poses = np.column_stack([rng.uniform(0.3, 5.7, n_particles), rng.uniform(0.3, 3.7, n_particles),
                             rng.uniform(-np.pi, np.pi, n_particles)])
    cases = []
    for n_beams in (24, 360):
        field = FieldCase(grid, np.linspace(-np.pi, np.pi, n_beams, endpoint=False))
        z = rng.uniform(0.1, field.max_range, n_beams)
        z[rng.random(n_beams) < 0.2] = field.max_range  # no echo
        cases.append((z, field))
    answers = _cloud_answers(report, [lambda z=z, f=f: fn(poses.copy(), z.copy(), f) for z, f in cases],
                             "fn(poses, z, field)", "compute and return one log-weight per pose", n_particles,
                             "log-weight per pose (a row of poses), summed over the beams")
    if answers is None:
        return report

    def fits(mistake: str | None) -> bool:
        return all(np.allclose(a, field_log_weights(poses, z, f, mistake), rtol=rtol, atol=1e-9)
                   for a, (z, f) in zip(answers, cases))

    if _settled(report, fits, FIELD_MISTAKES):
        return report
    if any(np.isnan(a).any() for a in answers):
        report.problems.append("some log-weights are NaN: an end point off the map is infinitely far from a wall "
                               "(distance_at returns inf), whose Gaussian term is 0, not NaN")
        return report
    report.problems.append("the log-weights differ from table 6.3's: for each beam shorter than z_max, find its end "
                           "point, read its distance d to the nearest wall, and add log(z_hit N(d; 0, sigma^2) + "
                           "z_rand / z_max)")
    return report


#: The scanner of :func:`check_beam_reading`: the book's, with more short readings and lambda = 2 per m
#: (so that an exponential of scale lambda instead of 1 / lambda shows).
BEAM_CASE = dict(z_hit=0.75, z_short=0.1, z_max=0.05, z_rand=0.1, sigma_hit=0.05, lambda_short=2.0, max_range=8.0)
#: The typical mistakes of a beam-model reading, each detected by its own test (tests/test_exercises.py).
Z_STAR = 0.75  # m, the true range of every beam of the check
BEAM_MISTAKES = ("hit_unclipped", "global_rng", "no_max", "rand_to_z_star", "short_untruncated", "short_scale",
                 "hit_no_noise", "hit_variance_as_sd", "hit_double_sd", "max_rand_swapped", "one_part_per_scan")


def beam_reading_reference(z_star, scanner, rng, mistake: str | None = None):
    """One reading per beam by the four-part beam model (:meth:`pfcourse.scenarios.maprobot.Scanner.sample`), or
    a mistake of :data:`BEAM_MISTAKES`."""
    z_star = np.asarray(z_star, dtype=float)
    if mistake == "global_rng":
        rng = np.random.mtrand._rand
    u = rng.random((4, len(z_star)))
    if mistake == "one_part_per_scan":
        u[0] = u[0, 0]
    p_max = scanner.z_rand if mistake == "max_rand_swapped" else scanner.z_max
    part = np.searchsorted(np.cumsum([scanner.z_hit, scanner.z_short, p_max]), u[0], side="right")
    sd = {"hit_no_noise": 0.0, "hit_variance_as_sd": scanner.sigma_hit ** 2,
          "hit_double_sd": 2.0 * scanner.sigma_hit}.get(mistake, scanner.sigma_hit)
    hit = z_star + sd * stats.norm.ppf(u[1])
    hit = hit if mistake == "hit_unclipped" else np.clip(hit, 0.0, scanner.max_range)
    lam = 1.0 / scanner.lambda_short if mistake == "short_scale" else scanner.lambda_short
    cut = 1.0 if mistake == "short_untruncated" else -np.expm1(-lam * z_star)
    short = -np.log1p(-u[2] * cut) / lam
    rand = u[3] * (z_star if mistake == "rand_to_z_star" else scanner.max_range)
    no_echo = rand if mistake == "no_max" else np.full_like(z_star, scanner.max_range)
    return np.choose(part, [hit, short, no_echo, rand])


def check_beam_reading(fn: Callable, n_beams: int = 100000, seed: int = 0) -> CheckReport:
    """Check a student's ``fn(z_star, scanner, rng) -> z``: one reading per beam (``z_star`` ``(B,)``, the
    true ranges) drawn from the four-part beam model of ``scanner`` (its ``z_hit, z_short, z_max, z_rand,
    sigma_hit, lambda_short, max_range``; :data:`BEAM_CASE`) with the generator ``rng``.

    Every beam has ``z* = 0.75 m`` (and ``7.98 m`` for the clipping test): the shares of readings below
    ``z* - 0.2``, within ``0.2`` of ``z*``, beyond ``z* + 0.2`` and at ``z_max``, and the mean short
    reading, must agree with the model's within five standard errors; the draws must come from ``rng``."""
    from types import SimpleNamespace

    report = CheckReport("beam-model reading")
    scanner = SimpleNamespace(**BEAM_CASE)
    zmax = scanner.max_range
    state = np.random.get_state()
    calls = [(np.full(n_beams, Z_STAR), seed), (np.full(n_beams, Z_STAR), seed), (np.full(n_beams, Z_STAR), seed + 1),
             (np.full(n_beams, zmax - 0.02), seed)]
    answers = []
    for z_star, s in calls:
        a = _answer(report, lambda: fn(z_star.copy(), scanner, np.random.default_rng(s)), "fn(z_star, scanner, rng)",
                    "return the array of readings, one per beam")
        if a is None:
            np.random.set_state(state)
            return report
        a = np.asarray(a, dtype=float)
        if a.shape != z_star.shape:
            np.random.set_state(state)
            report.problems.append(f"the readings have shape {a.shape}, not {z_star.shape}: one reading per beam")
            return report
        answers.append(a)
    z, again, other, far = answers
    if np.any(~np.isfinite(z)) or np.any(z < 0) or np.any(far < 0):
        np.random.set_state(state)
        report.problems.append("a reading is negative or not finite: every part of the beam model gives a range in "
                               "[0, z_max]")
        return report
    if np.any(far > zmax + 1e-9):
        np.random.set_state(state)
        report.problems.append("some readings exceed z_max: a hit drawn beyond the maximum range must be clipped to "
                               "z_max (the scanner reports nothing farther)")
        return report
    from pfcourse.book.exercises.part1 import _seed_problem

    problem = _seed_problem(state, (z,), (again,), (other,), "readings", "rng.random(), rng.normal(), ...")
    if problem:
        report.problems.append(problem)
        return report
    # one part drawn for a whole scan: some scan of 400 beams is all hits or has almost none
    for i in range(20):
        scan = np.asarray(fn(np.full(400, Z_STAR), scanner, np.random.default_rng(seed + 2 + i)), dtype=float)
        near = np.mean(np.abs(scan - Z_STAR) <= 0.2)
        if near > 0.99 or near < 0.3:
            np.random.set_state(state)
            report.problems.append(f"in one scan of 400 beams {near:.0%} of the readings lie within 0.2 m of z*, the "
                                   "model gives about 77 %: draw the part (hit, short, no echo, random) of each beam "
                                   "separately, not one part for the whole scan")
            return report
    ref = beam_reading_reference(np.full(400000, Z_STAR), scanner, np.random.default_rng(12345))

    # the spread of the hits: the share of the readings within 0.2 m of z* that lie within 0.05 m of it
    def tight(x):
        near = np.abs(x - Z_STAR) <= 0.2
        return np.mean(np.abs(x[near] - Z_STAR) <= scanner.sigma_hit), near.sum()

    (t_got, n_got), (t_want, n_ref) = tight(z), tight(ref)
    # 0.05 absorbs what other mistakes (a short or random part of the wrong shape) move this share by
    if abs(t_got - t_want) > max(5 * np.sqrt(t_want * (1 - t_want) * (1 / n_got + 1 / n_ref)), 0.05):
        np.random.set_state(state)
        said = (f"{t_got:.2f} of the readings within 0.2 m of z* lie within sigma_hit of it, the model gives "
                f"{t_want:.2f}: a hit is z* plus Gaussian noise of standard deviation sigma_hit")
        if np.mean(z == Z_STAR) > 0.5:
            said += "; here most readings equal z* exactly: the hit has no noise"
        elif t_got > t_want:
            said += ", not sigma_hit**2 (the hits are too tight: is the variance used as the standard deviation?)"
        else:
            said += ", not twice sigma_hit (the hits are too wide)"
        report.problems.append(said)
        return report

    def shares(x):
        return np.array([np.mean(x < Z_STAR - 0.2), np.mean(np.abs(x - Z_STAR) <= 0.2),
                         np.mean((x > Z_STAR + 0.2) & (x < zmax)),
                         np.mean(x >= zmax)])

    got, want = shares(z), shares(ref)
    se = np.sqrt(want * (1 - want) / n_beams + want * (1 - want) / len(ref))
    off = np.abs(got - want) > 5 * se + 1e-12
    if off[3] and got[3] > want[3]:
        report.problems.append(f"{got[3]:.3f} of the readings are at z_max, the model gives {want[3]:.3f}: the "
                               "reading z_max comes with probability z_max and a uniform reading with z_rand (are the two weights "
                               "swapped?)")
    elif off[3] and got[3] < want[3]:
        report.problems.append(f"{got[3]:.3f} of the readings are at z_max, the model gives {want[3]:.3f}: the "
                               "no-echo part returns exactly z_max with probability z_max")
    elif off[2] and got[2] < want[2]:
        report.problems.append(f"{got[2]:.3f} of the readings lie beyond z* + 0.2 m, the model gives {want[2]:.3f}: "
                               "the random part is uniform on [0, z_max], not on [0, z*]")
    elif off[2]:
        report.problems.append(f"{got[2]:.3f} of the readings lie beyond z* + 0.2 m, the model gives {want[2]:.3f}: "
                               "a short reading is an exponential truncated to [0, z*] (something in the way is "
                               "nearer than the wall)")
    elif off[0] and not off[3]:
        report.problems.append(f"{got[0]:.3f} of the readings lie below z* - 0.2 m, the model gives {want[0]:.3f}: "
                               "a short reading is Exp(lambda_short), of rate lambda_short (mean 1 / lambda_short "
                               "before truncation; numpy's rng.exponential takes the scale 1 / lambda)")
    elif off.any():
        names = ["below z* - 0.2 m", "within 0.2 m of z*", "beyond z* + 0.2 m", "at z_max"]
        k = int(np.argmax(np.abs(got - want) / np.maximum(se, 1e-12)))
        report.problems.append(f"{got[k]:.3f} of the readings are {names[k]}, the model gives {want[k]:.3f}: draw the "
                               "part of each beam with probabilities z_hit, z_short, z_max, z_rand, then its reading")
    else:
        low, ref_low = z[z < Z_STAR - 0.2], ref[ref < Z_STAR - 0.2]
        se_mean = np.sqrt(ref_low.var() / len(low) + ref_low.var() / len(ref_low))
        if abs(low.mean() - ref_low.mean()) > 5 * se_mean:
            report.problems.append(f"the short readings average {low.mean():.3f} m, the model's {ref_low.mean():.3f} "
                                   "m: Exp(lambda_short) has rate lambda_short, so mean 1 / lambda_short before "
                                   "truncation (numpy's exponential takes the scale 1 / lambda)")
    return report




ALTITUDE_MISTAKES: dict[str, str] = {
    "ground_sign": "the ground height has the wrong sign: the altimeter reads altitude minus ground, so the "
                   "predicted reading is m - h(p) and the innovation y - m + h(p)",
    "weight_with_r": "the weight uses Rf where it needs S = P + Rf: the altitude is uncertain, so the predictive "
                     "density of the reading is N(y; m - h(p), P + Rf), not N(y; m - h(p), Rf)",
    "no_var_update": "the variance is not updated: after a reading P' = (1 - K) P, smaller than P",
    "gain_over_r": "the gain is P / Rf: it is K = P / (P + Rf), which stays below one",
}


def altitude_update(mean: np.ndarray, var: np.ndarray, ground: np.ndarray, reading: float, rf: float,
                    mistake: str | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every particle's altitude update: ``(m', P', log N(nu; 0, S))`` with ``nu = y - (m - h)``, ``S = P + Rf``,
    ``K = P / S``, ``m' = m + K nu``, ``P' = (1 - K) P``.  ``mistake`` (a key of :data:`ALTITUDE_MISTAKES`)
    computes instead what that mistake computes."""
    if mistake is not None and mistake not in ALTITUDE_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(ALTITUDE_MISTAKES)}")
    nu = reading - (mean + ground if mistake == "ground_sign" else mean - ground)
    s = var + rf
    gain = var / (rf if mistake == "gain_over_r" else s)
    s_lik = rf if mistake == "weight_with_r" else s
    log_lik = -0.5 * (nu * nu / s_lik + np.log(2 * np.pi * s_lik))
    return mean + gain * nu, var if mistake == "no_var_update" else (1.0 - gain) * var, log_lik


#: Five particles over the terrain: predicted altitude means, their common variance, ground heights, a reading, Rf.
ALTITUDE_CASE = dict(mean=np.array([1500.0, 1460.0, 1530.0, 1495.0, 1510.0]), var=np.full(5, 900.0),
                     ground=np.array([250.0, 310.0, 180.0, 270.0, 205.0]), reading=1225.0, rf=400.0)


def _check_update(report: CheckReport, fn: Callable, case: Mapping[str, object], call: tuple[str, str],
                  parse: Callable[[object], tuple], shape_problem: str, reference: Callable[[str | None], tuple],
                  mistakes: Mapping[str, str], parts: tuple[str, ...], tol: tuple[float, float],
                  differs: str) -> CheckReport:
    """The skeleton of the Kalman-update checkers: ``fn(**case)`` is called on copies of the case's arrays (``call``:
    its signature and what it returns, for :func:`_answer`), its answer split into outputs by ``parse`` (which
    raises ``TypeError`` or ``ValueError`` on a wrong shape: ``shape_problem`` is reported), and the outputs ``g``
    compared with ``reference(None)``'s ``e``, output by output, ``|g - e| <= atol + rtol |e|`` (``np.allclose``,
    ``tol = (rtol, atol)``). Equal outputs pass; outputs equal to ``reference(mistake)`` for a key of ``mistakes``
    name that mistake; else ``differs``, formatted with the name (of ``parts``) of the first output that is not
    equal, says which line to check."""
    copy = {key: np.copy(value) if isinstance(value, np.ndarray) else value for key, value in case.items()}
    answer = _answer(report, lambda: fn(**copy), *call)
    if answer is None:
        return report
    try:
        got = parse(answer)
    except (TypeError, ValueError):
        report.problems.append(shape_problem)
        return report
    rtol, atol = tol

    def same(expected: tuple) -> bool:
        return all(np.allclose(g, e, rtol=rtol, atol=atol) for g, e in zip(got, expected))

    if same(reference(None)):
        return report
    for mistake, why in mistakes.items():
        if same(reference(mistake)):
            report.problems.append(f"your update computes a known mistake: {why}")
            return report
    exact = reference(None)
    part = next(name for name, g, e in zip(parts, got, exact) if not np.allclose(g, e, rtol=rtol, atol=atol))
    report.problems.append(differs.format(part=part))
    return report


def check_altitude_update(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check a student's ``fn(mean, var, ground, reading, rf) -> (mean_new, var_new, log_lik)`` on
    :data:`ALTITUDE_CASE`: each output must equal :func:`altitude_update` to ``rtol``; one that does not
    is compared with every mistake of :data:`ALTITUDE_MISTAKES`, and the report names the one that fits."""
    def parse(answer) -> tuple:
        got = tuple(np.broadcast_to(np.asarray(part, dtype=float), (5,)) for part in answer)
        if len(got) != 3:
            raise ValueError
        return got

    return _check_update(
        CheckReport("altitude Kalman update of every particle"), fn, ALTITUDE_CASE,
        ("fn(mean, var, ground, reading, rf)", "return (mean_new, var_new, log_lik)"), parse,
        "return three arrays of one value per particle (shape (5,)): the new means, the new variances and the "
        "log-weight increments", lambda mistake: altitude_update(**ALTITUDE_CASE, mistake=mistake),
        ALTITUDE_MISTAKES, ("mean", "variance", "log-weight increment"), (rtol, 1e-12),
        "the {part} differs from the Kalman update (nu = y - (m - h), S = P + Rf, K = P / S, m' = m + K nu, "
        "P' = (1 - K) P, log N(nu; 0, S)): check that line")


#: The typical mistakes of the two-state (altitude, map bias) Kalman update, and why each is wrong.
BIAS_MISTAKES: dict[str, str] = {
    "bias_ignored": "the predicted reading leaves out the map bias: the reading is z + b - h_f(p), so the "
                    "innovation is y - (m_z + m_b - h_f) and H = [1, 1]",
    "no_cross_term": "S leaves out the covariance of altitude and bias: with H = [1, 1], S = P_zz + 2 P_zb + "
                     "P_bb + Rf, and after the first reading P_zb is not zero",
    "weight_with_r": "the weight uses Rf where it needs S = H P H^T + Rf: altitude and bias are uncertain, so the "
                     "predictive density of the reading is N(nu; 0, S), not N(nu; 0, Rf)",
    "no_cov_update": "the covariance is not updated: after a reading P' = P - K K^T S, smaller than P",
    "one_gain": "both states get the altitude's gain: the gain is K = P H^T / S, (P_zz + P_zb) / S for the "
                "altitude and (P_zb + P_bb) / S for the bias",
    "innovation_flipped": "the innovation has the wrong sign: nu = y - (m_z + m_b - h_f), the reading minus its "
                          "prediction, so a reading above the prediction moves the means up",
    "ground_added": "the ground height is added: the altimeter reads the height above the ground, so the "
                    "predicted reading is m_z + m_b - h_f, with the ground subtracted",
    "covariance_order": "the covariance columns are in the wrong order: return them as (P_zz, P_zb, P_bb), "
                        "the altitude's variance, the cross term, the bias's variance",
}


def bias_update(m: np.ndarray, P: np.ndarray, ground: np.ndarray, reading: float, rf: float,
                mistake: str | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every particle's update of ``(z, b)``: ``m`` ``(N, 2)``, ``P`` ``(N, 3)`` = ``(P_zz, P_zb, P_bb)``,
    ``H = [1, 1]``; returns ``(m', P', log N(nu; 0, S))``.  ``mistake`` (a key of :data:`BIAS_MISTAKES`)
    computes instead what that mistake computes."""
    if mistake is not None and mistake not in BIAS_MISTAKES:
        raise ValueError(f"unknown mistake {mistake!r}; one of {sorted(BIAS_MISTAKES)}")
    pzz, pzb, pbb = P[:, 0], P[:, 1], P[:, 2]
    predicted = m[:, 0] + (ground if mistake == "ground_added" else -ground) + (0.0 if mistake == "bias_ignored"
                                                                             else m[:, 1])
    nu = predicted - reading if mistake == "innovation_flipped" else reading - predicted
    s = pzz + (0.0 if mistake == "no_cross_term" else 2.0 * pzb) + pbb + rf
    kz = (pzz + pzb) / s
    kb = kz if mistake == "one_gain" else (pzb + pbb) / s
    s_lik = rf if mistake == "weight_with_r" else s
    log_lik = -0.5 * (nu * nu / s_lik + np.log(2 * np.pi * s_lik))
    m_new = np.column_stack([m[:, 0] + kz * nu, m[:, 1] + kb * nu])
    P_new = P.copy() if mistake == "no_cov_update" else np.column_stack(
        [pzz - kz * kz * s, pzb - kz * kb * s, pbb - kb * kb * s])
    if mistake == "covariance_order":  # (P_zz, P_bb, P_zb)
        P_new = P_new[:, [0, 2, 1]]
    return m_new, P_new, log_lik


#: Five particles after some readings: (altitude, bias) means, covariances (P_zz, P_zb, P_bb) with a
#: non-zero cross term, ground heights on the filter's map, a reading, Rf.
BIAS_CASE = dict(m=np.array([[1500.0, 4.0], [1460.0, -6.0], [1530.0, 2.5], [1495.0, 0.0], [1510.0, -1.5]]),
                 P=np.tile([300.0, -80.0, 120.0], (5, 1)), ground=np.array([250.0, 310.0, 180.0, 270.0, 205.0]),
                 reading=1225.0, rf=400.0)


def check_bias_update(fn: Callable, rtol: float = 1e-9) -> CheckReport:
    """Check ``fn(m, P, ground, reading, rf) -> (m_new, P_new, log_lik)`` on :data:`BIAS_CASE` against
    :func:`bias_update`; a wrong answer is compared with every mistake of :data:`BIAS_MISTAKES`, and the report
    names the one that fits."""
    def parse(answer) -> tuple:
        if len(answer) != 3:
            raise ValueError
        shapes = ((5, 2), (5, 3), (5,))
        return tuple(np.asarray(part, dtype=float).reshape(shape) for part, shape in zip(answer, shapes))

    return _check_update(
        CheckReport("altitude and map-bias Kalman update of every particle"), fn, BIAS_CASE,
        ("fn(m, P, ground, reading, rf)", "return (m_new, P_new, log_lik)"), parse,
        "return three arrays: the new means (N, 2), the new covariances (N, 3) as (P_zz, P_zb, P_bb), and the "
        "log-weight increments (N,)", lambda mistake: bias_update(**BIAS_CASE, mistake=mistake),
        BIAS_MISTAKES, ("means", "covariances", "log-weight increments"), (rtol, 1e-9),
        "the {part} differ from the Kalman update with H = [1, 1] (nu = y - (m_z + m_b - h_f), S = H P H^T + Rf, "
        "K = P H^T / S, m' = m + K nu, P' = P - K K^T S, log N(nu; 0, S)): check that line")


def _wrap(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a, dtype=float), 2 * np.pi)


#: A cloud of robot poses ``(x, y, theta)`` around ``(1, -50, 0.02)`` and landmark ``(-20, -50)`` seen
#: right behind: predicted bearings straddle the cut at +-pi, so a missing wrap shows.
RANGE_BEARING_LANDMARK = np.array([-20.0, -50.0])


RANGE_BEARING_Z = np.array([21.3, -3.13])


RANGE_BEARING_R = np.diag([0.5, np.deg2rad(1.0)]) ** 2 * 2.0


#: The typical mistakes of the log-weight of a range-bearing measurement, and why each is wrong.
RANGE_BEARING_MISTAKES = {
    "no_wrap": "the bearing innovation is not wrapped to (-pi, pi]: a bearing of 179 degrees against a "
               "prediction of -179 degrees is 2 degrees off, not 358, so well-placed particles lose their weight",
    "no_wrap_at_all": "the bearing innovation is not wrapped to (-pi, pi]: a bearing of 179 degrees against a "
                      "prediction of -179 degrees is 2 degrees off, not 358, so well-placed particles lose their weight",
    "no_heading": "the predicted bearing is the world direction atan2(dy, dx) without subtracting the "
                  "particle's heading theta: the sensor measures the bearing relative to the robot",
    "r_as_sd": "R is read as a matrix of standard deviations (you took its square): R holds variances",
    "no_constant": "the normalising term -log(2 pi) - log(det R) / 2 is missing: it cancels in the "
                   "normalised weights, but not in the likelihood of the data the filter estimates",
}


def range_bearing_log_weights(x: np.ndarray, landmark: np.ndarray, z: np.ndarray, R: np.ndarray,
                              mistake: str | None = None) -> np.ndarray:
    """``log N(nu^i; 0, R)`` with ``nu^i = (z_r - ||l - p^i||, wrap(z_b - (atan2(l_y - y^i, l_x - x^i) - theta^i)))``
    for every pose ``x^i = (x^i, y^i, theta^i)`` (rows of ``x``). ``mistake`` (a key of
    :data:`RANGE_BEARING_MISTAKES`) computes that mistake instead."""
    x = np.asarray(x, dtype=float)
    d = np.asarray(landmark, dtype=float) - x[:, :2]
    heading = 0.0 if mistake == "no_heading" else x[:, 2]
    bearing = np.arctan2(d[:, 1], d[:, 0]) - heading
    if mistake == "no_wrap_at_all":
        nu_b = z[1] - bearing
    elif mistake == "no_wrap":  # the prediction wrapped, the innovation not
        nu_b = z[1] - _wrap(bearing)
    else:
        nu_b = _wrap(z[1] - _wrap(bearing))
    nu = np.column_stack([z[0] - np.hypot(d[:, 0], d[:, 1]), nu_b])
    cov = R @ R if mistake == "r_as_sd" else R
    quad = np.einsum("ij,jk,ik->i", nu, np.linalg.inv(cov), nu)
    constant = 0.0 if mistake == "no_constant" else 2 * np.log(2 * np.pi) + np.linalg.slogdet(cov)[1]
    return -0.5 * (quad + constant)


def _named_mistake(report: CheckReport, answer: np.ndarray, reference: Callable, mistakes: Mapping[str, str],
                   rtol: float, what: str) -> CheckReport:
    """Pass when ``answer`` equals ``reference(None)`` to ``rtol``; else name the mistake of ``mistakes``
    whose ``reference(mistake)`` it equals (:func:`_settled`), or say in ``what`` which formula to check."""
    if not _settled(report, lambda m: np.allclose(answer, reference(m), rtol=rtol, atol=1e-12), mistakes):
        report.problems.append(what)
    return report


def check_range_bearing_log_weights(fn: Callable, n_particles: int = 40, seed: int = 0,
                                    rtol: float = 1e-9) -> CheckReport:
    """Check ``fn(x, landmark, z, R) -> (N,)``: the log-likelihood ``log N(nu^i; 0, R)`` of a range-bearing
    measurement ``z = (range, bearing)`` of ``landmark`` for a cloud ``x`` of robot poses ``(N, 3)``.

    The case (:data:`RANGE_BEARING_Z`) has predicted bearings on both sides of the cut at +-pi.
    The answer must equal :func:`range_bearing_log_weights` to ``rtol``; otherwise the report names
    the mistake of :data:`RANGE_BEARING_MISTAKES` it equals.
    """
    report = CheckReport("range-bearing log-weights")
    x = np.random.default_rng(seed).normal([1.0, -50.0, 0.02], [0.5, 0.5, 0.03], size=(n_particles, 3))
    x[:, 2] = _wrap(x[:, 2])
    args = (RANGE_BEARING_LANDMARK, RANGE_BEARING_Z, RANGE_BEARING_R)
    answer = _answer(report, lambda: fn(x.copy(), *(a.copy() for a in args)), "fn(x, landmark, z, R)",
                     "compute and return one log-weight per particle")
    if answer is None or not _shaped(report, answer, (n_particles,), "one log-weight per particle (a row of x)"):
        return report
    return _named_mistake(report, answer, lambda m: range_bearing_log_weights(x, *args, mistake=m),
                          RANGE_BEARING_MISTAKES, rtol,
                          "the values differ from log N(nu; 0, R): check the innovation "
                          "nu = (z_r - range, wrap(z_b - bearing)) and the quadratic form nu^T R^-1 nu / 2")


#: The velocity motion model's check (chapter 11's exercise): every particle starts at the same pose, heading
#: 3 rad, so that the new headings cross the cut at +-pi; command (v, omega), its noise sds, and the step (s).
VELOCITY_POSE = np.array([0.0, 0.0, 3.0])
VELOCITY_U = np.array([2.0, 0.8])
VELOCITY_SD = np.array([0.2, 0.1])
VELOCITY_DT = 1.5
#: The typical mistakes of the velocity motion model, and why each is wrong (the statistical ones: their
#: large-cloud statistics are compared with the answer's).
VELOCITY_MISTAKES = {
    "straight": ("you move the particle in a straight line along its old heading (x + v cos(theta) dt): the "
                 "velocity model drives along an arc of radius v / omega, x' = x + v/omega (sin(theta + omega "
                 "dt) - sin(theta))"),
    "turn_sign": ("your arc turns the wrong way: with omega > 0 the robot turns left, y' = y + v/omega "
                  "(cos(theta) - cos(theta + omega dt)), not the opposite difference"),
    "sd_as_variance": ("your cloud is too narrow: sd holds standard deviations, so the noisy command is "
                       "v + sd_v * e, not v + sd_v**2 * e (or a draw with variance sd)"),
    "pose_noise": ("you add the noise to the new pose instead of to the command (v, omega): the model's "
                   "noise perturbs the speed and the turn rate, and the cloud bends along the arc"),
}


def velocity_motion(x: np.ndarray, u: np.ndarray, sd: np.ndarray, dt: float, rng: np.random.Generator,
                    mistake: str | None = None) -> np.ndarray:
    """The velocity motion model (Thrun, Burgard and Fox 2005, table 5.3, without its third noise): every pose
    ``(x, y, theta)`` of ``x`` (N, 3) drives along an arc with its own noisy command ``(v, omega) + sd * e``,
    ``e ~ N(0, I)``; the heading wrapped to (-pi, pi]. ``mistake`` (a key of :data:`VELOCITY_MISTAKES`)
    computes that mistake instead."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    scale = np.asarray(sd) ** 2 if mistake == "sd_as_variance" else np.asarray(sd)
    e = rng.standard_normal((n, 2))
    v, w = (u[0], u[1]) if mistake == "pose_noise" else (u[0] + scale[0] * e[:, 0], u[1] + scale[1] * e[:, 1])
    th, th_new = x[:, 2], x[:, 2] + w * dt
    if mistake == "straight":
        px, py = x[:, 0] + v * np.cos(th) * dt, x[:, 1] + v * np.sin(th) * dt
    else:
        r = v / w
        turn = -1.0 if mistake == "turn_sign" else 1.0
        px = x[:, 0] + r * (np.sin(th_new) - np.sin(th))
        py = x[:, 1] + turn * r * (np.cos(th) - np.cos(th_new))
    out = np.column_stack([px, py, _wrap(th_new)])
    if mistake == "pose_noise":  # the same spread, put on the pose: v dt along x and y, omega dt on theta
        out += np.column_stack([scale[0] * dt * e, scale[1] * dt * rng.standard_normal(n)])
        out[:, 2] = _wrap(out[:, 2])
    return out


def _motion_features(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Means and standard deviations of ``(x, y, cos theta, sin theta)`` over a cloud."""
    f = np.column_stack([x[:, 0], x[:, 1], np.cos(x[:, 2]), np.sin(x[:, 2])])
    return f.mean(axis=0), f.std(axis=0)


def check_velocity_motion(fn: Callable, n: int = 100_000, seed: int = 0) -> CheckReport:
    """Check ``fn(x, u, sd, dt, rng) -> (N, 3)``, the velocity motion model, leaving NumPy's global state
    as it was (:func:`_check_velocity_motion`)."""
    saved = np.random.get_state()
    try:
        return _check_velocity_motion(fn, n, seed)
    finally:
        np.random.set_state(saved)


def _check_velocity_motion(fn: Callable, n: int, seed: int) -> CheckReport:
    """In turn: the answer's shape and finiteness; headings wrapped to (-pi, pi]; a cloud that spreads (one
    noise draw per particle, not one shared); the generator (:func:`~pfcourse.book.exercises.part1._generator_problem`);
    then the means and standard deviations of ``(x, y, cos theta, sin theta)`` over ``n`` particles against
    those of 4n reference draws: every difference within 6 standard errors (a correct answer's largest of the
    eight is below 4 in all but about 1 in 4000 checks). A failure is compared with each typical mistake of
    :data:`VELOCITY_MISTAKES`, so that it is named."""
    from pfcourse.book.exercises.part1 import _generator_problem

    report = CheckReport("velocity motion model")
    start = np.tile(VELOCITY_POSE, (n, 1))
    args = (VELOCITY_U, VELOCITY_SD, VELOCITY_DT)
    answer = _answer(report, lambda: fn(start.copy(), *(np.copy(a) for a in args), np.random.default_rng(seed)),
                     "fn(x, u, sd, dt, rng)", "return the moved cloud, one pose (x, y, theta) per row of x")
    if answer is None or not _shaped(report, answer, (n, 3), "one moved pose (x, y, theta) per row of x"):
        return report
    answer = np.asarray(answer, dtype=float)
    if not np.isfinite(answer).all():
        report.problems.append("the cloud holds NaN or infinity: the arc's radius v / omega needs omega != 0; "
                               "check the division")
        return report
    if np.any(np.abs(answer[:, 2]) > np.pi + 1e-9):
        report.problems.append("some headings lie outside (-pi, pi]: wrap theta + omega dt, or the heading "
                               "drifts off by multiples of 2 pi and circular means break")
        return report
    if np.all(answer[:, :2].std(axis=0) < 1e-9):
        report.problems.append("every particle lands on the same pose: draw one noise pair per particle "
                               "(rng.standard_normal((N, 2))), not one pair shared by the whole cloud")
        return report
    problem = _generator_problem(lambda rng: fn(start[:200].copy(), *(np.copy(a) for a in args), rng),
                                 lambda a, b: np.array_equal(np.asarray(a), np.asarray(b)), what="cloud")
    if problem:
        report.problems.append(problem)
        return report
    mean, sd = _motion_features(answer)

    def fits(mistake: str | None) -> bool:
        ref = velocity_motion(np.tile(VELOCITY_POSE, (4 * n, 1)), *args, np.random.default_rng(10_000),
                              mistake=mistake)
        ref_mean, ref_sd = _motion_features(ref)
        se_mean = np.sqrt(sd**2 / n + ref_sd**2 / (4 * n)) + 1e-12
        se_sd = ref_sd * np.sqrt(1 / (2 * n) + 1 / (8 * n)) * 2 + 1e-12  # doubled: the features are not Gaussian
        return max(np.max(np.abs(mean - ref_mean) / se_mean), np.max(np.abs(sd - ref_sd) / se_sd)) <= 6

    if not _settled(report, fits, VELOCITY_MISTAKES):
        report.problems.append("the moved cloud's mean or spread differs from the velocity model's: draw "
                               "(v, omega) + sd * e for each particle, then move along the arc of radius v / omega")
    return report


#: The typical mistakes of the measurement Jacobian of range and bearing, and why each is wrong.
JACOBIAN_MISTAKES = {
    "offset_reversed": "the signs of the position columns are reversed: with (dx, dy) = l - p the range "
                       "shrinks as the robot moves towards the landmark, so d range / dx = -dx / sqrt(q)",
    "heading_plus": "d bearing / d theta is +1: the bearing is atan2(dy, dx) - theta, so it is -1",
    "range_over_q": "the range row divides by q = dx^2 + dy^2 instead of sqrt(q): d sqrt(q) / dx = -dx / sqrt(q)",
    "bearing_swapped": "the bearing row swaps dx and dy: d atan2(dy, dx) / dx = dy / q and / dy = -dx / q",
}


JACOBIAN_CASES = (
    (np.array([1.0, -50.0, 0.3]), np.array([-20.0, -45.0])),
    (np.array([12.0, 7.0, -2.9]), np.array([15.0, 31.0])),
    (np.array([-3.0, 4.0, 3.1]), np.array([-40.0, -2.0])),
)


def range_bearing_jacobian(state: np.ndarray, landmark: np.ndarray, mistake: str | None = None) -> np.ndarray:
    """``H = dh/dx`` (2x3) of ``h(x) = (sqrt(q), atan2(dy, dx) - theta)``, ``(dx, dy) = l - p``, ``q = dx^2 + dy^2``:
    ``[[-dx/sqrt(q), -dy/sqrt(q), 0], [dy/q, -dx/q, -1]]``. ``mistake`` (a key of :data:`JACOBIAN_MISTAKES`)
    computes that mistake instead."""
    dx, dy = np.asarray(landmark, dtype=float) - np.asarray(state, dtype=float)[:2]
    q = dx * dx + dy * dy
    sign = -1.0 if mistake == "offset_reversed" else 1.0
    r = q if mistake == "range_over_q" else np.sqrt(q)
    bx, by = (-dx / q, dy / q) if mistake == "bearing_swapped" else (dy / q, -dx / q)
    return np.array([[-sign * dx / r, -sign * dy / r, 0.0],
                     [sign * bx, sign * by, 1.0 if mistake == "heading_plus" else -1.0]])


def check_range_bearing_jacobian(fn: Callable, rtol: float = 1e-6) -> CheckReport:
    """Check ``fn(state, landmark) -> (2, 3)``, the EKF's measurement Jacobian of range and bearing.

    On each case of :data:`JACOBIAN_CASES` the answer must equal :func:`range_bearing_jacobian` to
    ``rtol`` (so a careful finite difference passes too); otherwise the report names the mistake of
    :data:`JACOBIAN_MISTAKES` it equals.
    """
    report = CheckReport("range-bearing Jacobian")
    answers = []
    for state, landmark in JACOBIAN_CASES:
        answer = _answer(report, lambda: fn(state.copy(), landmark.copy()), "fn(state, landmark)",
                         "compute and return the 2 x 3 matrix H")
        if answer is None:
            return report
        if not _shaped(report, answer, (2, 3), "one row per measured quantity (range, bearing), one column "
                                               "per state component (x, y, theta)"):
            return report
        answers.append(np.asarray(answer, dtype=float))
    return _named_mistake(report, np.array(answers),
                          lambda m: np.array([range_bearing_jacobian(s, lm, m) for s, lm in JACOBIAN_CASES]),
                          JACOBIAN_MISTAKES, rtol,
                          "the matrix differs from dh/dx: differentiate sqrt(q) and atan2(dy, dx) - theta "
                          "with (dx, dy) = l - p, and compare with a central finite difference")

#: The landmark measured in the robot's frame (chapter 13's exercise): ``z = R(theta)^T (l - p)``, the
#: typical mistakes of its Jacobian and why each is wrong.
RELATIVE_MISTAKES = {
    "no_transpose": "you differentiate R(theta) (l - p): the landmark in the robot's frame is R(theta)^T (l - p), "
                    "the world offset turned by -theta, so row 1 is (-cos, -sin) and row 2 (sin, -cos) in x and y",
    "offset_reversed": "the signs of the position columns are reversed: the offset is l - p, so moving the "
                       "robot by +dx moves the landmark by -dx in its frame: d z / d(x, y) = -R(theta)^T",
    "no_theta": "the heading column is zero: turning the robot turns the landmark in its frame, "
                "d z / d theta = (-sin dx + cos dy, -cos dx - sin dy) with (dx, dy) = l - p",
    "theta_sign": "the heading column has the wrong sign: d z / d theta = (-sin dx + cos dy, -cos dx - sin dy), "
                  "the offset turned by -theta - pi/2",
}


def relative_landmark_jacobian(state: np.ndarray, landmark: np.ndarray, mistake: str | None = None) -> np.ndarray:
    """``H = d z / d (x, y, theta)`` of ``z = R(theta)^T (l - p)``, the landmark in the robot's frame (2, 3).
    ``mistake`` (a key of :data:`RELATIVE_MISTAKES`) computes that mistake instead."""
    c, s = np.cos(state[2]), np.sin(state[2])
    dx, dy = landmark[0] - state[0], landmark[1] - state[1]
    if mistake == "no_transpose":
        return np.array([[-c, s, -s * dx - c * dy], [-s, -c, c * dx - s * dy]])
    pos = np.array([[-c, -s], [s, -c]])
    theta = np.array([-s * dx + c * dy, -c * dx - s * dy])
    if mistake == "offset_reversed":
        pos = -pos
    if mistake == "no_theta":
        theta = np.zeros(2)
    if mistake == "theta_sign":
        theta = -theta
    return np.column_stack([pos, theta])


#: Poses and landmarks of :func:`check_relative_jacobian`: headings away from 0 and pi/2, where
#: swapped sines and cosines would pass.
RELATIVE_CASES = (
    (np.array([1.0, -2.0, 0.7]), np.array([12.0, 5.0])),
    (np.array([-3.0, 4.0, -2.4]), np.array([-20.0, -6.0])),
    (np.array([0.5, 0.5, 2.9]), np.array([8.0, -15.0])),
)


def check_relative_jacobian(fn: Callable, rtol: float = 1e-6) -> CheckReport:
    """Check ``fn(state, landmark) -> (2, 3)``: the Jacobian of the landmark measured in the robot's frame,
    ``z = R(theta)^T (l - p)``, at the poses of :data:`RELATIVE_CASES` against
    :func:`relative_landmark_jacobian` (to ``rtol``: a careful central difference passes); the mistakes of
    :data:`RELATIVE_MISTAKES` are named. The function draws no random numbers: no generator to check."""
    report = CheckReport("relative-landmark Jacobian")
    answers = []
    for state, landmark in RELATIVE_CASES:
        answer = _answer(report, lambda: fn(state.copy(), landmark.copy()), "fn(state, landmark)",
                         "return the 2 x 3 matrix H = dz/dx")
        if answer is None or not _shaped(report, answer, (2, 3), "H = dz/dx, rows (forward, left), "
                                         "columns (x, y, theta)"):
            return report
        answers.append(np.asarray(answer, dtype=float))

    def fits(mistake: str | None) -> bool:
        return all(np.allclose(a, relative_landmark_jacobian(st, lm, mistake), rtol=rtol, atol=1e-9)
                   for a, (st, lm) in zip(answers, RELATIVE_CASES))

    if not _settled(report, fits, RELATIVE_MISTAKES):
        report.problems.append("H differs from the derivative of R(theta)^T (l - p): differentiate each of the two "
                               "coordinates in x, y and theta, and check the signs")
    return report
