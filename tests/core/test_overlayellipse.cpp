/* The mini-map's 95 % uncertainty ellipses (covariance_ellipse): for
 * covariances built from known axes, R diag (s1^2, s2^2) R^T with R a
 * turn by t, the semi-axes are sqrt (5.991) s1 and sqrt (5.991) s2 and
 * the major axis lies along t (modulo 180 degrees); for a covariance given
 * by its entries, the axes from the closed-form eigenvalues of a 2x2
 * matrix, (a + d) / 2 +- sqrt (((a - d) / 2)^2 + b^2). A covariance that
 * is not one is refused. */
#include <cmath>

#include "corecheck.h"
#include "overlaydraw.h"

using landmark::overlay::EllipseAxes;
using landmark::overlay::covariance_ellipse;

/* the difference of two axis directions, modulo 180 degrees */
static double
axis_difference (double a, double b)
{
  return std::fabs (std::remainder (a - b, M_PI));
}

static void
check_axes (double s1, double s2, double turn)
{
  const double c = std::cos (turn), s = std::sin (turn);
  const double v1 = s1 * s1, v2 = s2 * s2;
  const double cov[4] = { c * c * v1 + s * s * v2, c * s * (v1 - v2),
    c * s * (v1 - v2), s * s * v1 + c * c * v2
  };
  const EllipseAxes e = covariance_ellipse (cov);
  const double k = std::sqrt (5.991);
  CHECK (e.ok, "s1 %g s2 %g turn %g refused", s1, s2, turn);
  CHECK (std::fabs (e.major - k * s1) < 1e-12 * k * s1 + 1e-15,
      "major %.15g, want %.15g", e.major, k * s1);
  CHECK (std::fabs (e.minor - k * s2) < 1e-9 * k * s1 + 1e-15,
      "minor %.15g, want %.15g", e.minor, k * s2);
  if (s1 > s2 * (1 + 1e-6))
    CHECK (axis_difference (e.angle, turn) < 1e-9, "angle %.12g, want %.12g "
        "(mod pi)", e.angle, turn);
}

int
main ()
{
  /* a landmark: 4 cm by 1 cm, turned by 30 degrees */
  check_axes (0.04, 0.01, M_PI / 6);
  /* across the quadrants, and near the y axis */
  check_axes (0.2, 0.05, 2.0);
  check_axes (0.2, 0.05, -1.2);
  check_axes (1.0, 0.999, M_PI / 2);
  check_axes (3e-3, 1e-3, 0.0);
  /* a degenerate direction: a line, minor 0 */
  check_axes (0.1, 0.0, 0.7);
  /* a circle: both axes equal, any angle */
  check_axes (0.05, 0.05, 0.3);

  /* by its entries: a = 0.0009, b = 0.0004, d = 0.0004 (m^2) */
  {
    const double a = 9e-4, b = 4e-4, d = 4e-4;
    const double cov[4] = { a, b, b, d };
    const double mid = (a + d) / 2, half = std::hypot ((a - d) / 2, b);
    const EllipseAxes e = covariance_ellipse (cov);
    CHECK (e.ok, "refused");
    CHECK (std::fabs (e.major - std::sqrt (5.991 * (mid + half))) < 1e-12,
        "major %.15g", e.major);
    CHECK (std::fabs (e.minor - std::sqrt (5.991 * (mid - half))) < 1e-12,
        "minor %.15g", e.minor);
    /* the major axis of [[a, b], [b, d]]: tan 2t = 2b / (a - d) */
    CHECK (axis_difference (e.angle, 0.5 * std::atan2 (2 * b, a - d)) < 1e-9,
        "angle %g", e.angle);
    /* another confidence: the axes scale with its square root */
    const EllipseAxes e99 = covariance_ellipse (cov, 9.21);
    CHECK (std::fabs (e99.major / e.major - std::sqrt (9.21 / 5.991)) < 1e-12,
        "99 %% major %g", e99.major);
  }

  /* not a covariance */
  const double bad[][4] = {
    { 1e-4, 2e-4, 0.0, 1e-4 },     /* not symmetric */
    { 1e-4, 2e-4, 2e-4, 1e-4 },    /* an eigenvalue of -1e-4 */
    { NAN, 0, 0, 1e-4 },
    { INFINITY, 0, 0, 1e-4 },
  };
  for (const auto & cov : bad)
    CHECK (!covariance_ellipse (cov).ok, "accepted %g %g %g %g", cov[0],
        cov[1], cov[2], cov[3]);
  return corecheck_summary ();
}
