/* ColourDrift: the gains it estimates from class means that a known drift
 * made, its bounds, and the colours re-made with gains. */
#include <cmath>

#include "colourdrift.h"
#include "corecheck.h"

using namespace landmark;

/* one frame's sums: count pixels of each class at its colour under g */
static ClassColourSums
frame_under (const std::vector<Lab> & labs, const std::vector<unsigned> & n,
    const std::array<double, 3> & g)
{
  ClassColourSums s;
  s.reset (labs.size ());
  for (size_t k = 0; k < labs.size (); k++) {
    double rgb[3];
    lab_to_srgb (labs[k], rgb);
    for (int c = 0; c < 3; c++)
      s.sum[k][c] = n[k] * srgb_to_linear (rgb[c]) * g[c];
    s.count[k] = n[k];
  }
  return s;
}

static double
delta_e (const Lab & x, const Lab & y)
{
  return std::hypot (x.L - y.L, x.a - y.a, x.b - y.b);
}

int
main ()
{
  const std::vector<Lab> labs = { {60, 0, 0}, {50, 60, 45}, {70, -40, 50},
    {40, 30, -60} };
  /* the last class has several references (a ball): never counted */
  const std::vector<bool> single = { true, true, true, false };
  const std::vector<unsigned> n = { 4000, 300, 200, 500 };

  /* a drift inside the bounds: the gains converge on it */
  ColourDrift drift;
  drift.reset (labs, single);
  const std::array<double, 3> truth = { 0.6, 0.55, 0.52 };
  for (int i = 0; i < 200; i++) {
    ClassColourSums f = frame_under (labs, n, truth);
    /* the ball's pixels say something else entirely */
    for (int c = 0; c < 3; c++)
      f.sum[3][c] *= 3.0;
    CHECK (drift.update (f), "frame %d", i);
  }
  for (int c = 0; c < 3; c++)
    CHECK (std::fabs (drift.gains ()[c] / truth[c] - 1) < 1e-3, "c%d: %g",
        c, drift.gains ()[c]);
  /* smoothed: one frame of a different drift moves the gains by a tenth */
  const std::array<double, 3> before = drift.gains ();
  drift.update (frame_under (labs, n, {1.2, 1.1, 1.04}));
  CHECK (std::fabs (std::log (drift.gains ()[1] / before[1]) -
          ColourDrift::kSmoothing * std::log (1.1 / truth[1])) < 1e-9,
      "%g", drift.gains ()[1]);

  /* bounds: four times brighter is taken as twice; red 50 % above green
   * as 15 % */
  drift.reset (labs, single);
  for (int i = 0; i < 400; i++)
    drift.update (frame_under (labs, n, {6.0, 4.0, 4.0}));
  const auto & g = drift.gains ();
  CHECK (std::fabs (std::cbrt (g[0] * g[1] * g[2]) -
          ColourDrift::kMaxGain) < 1e-3, "exposure %g",
      std::cbrt (g[0] * g[1] * g[2]));
  CHECK (std::fabs (g[0] / g[1] - (1 + ColourDrift::kMaxBalance)) < 1e-3,
      "red/green %g", g[0] / g[1]);
  CHECK (std::fabs (g[2] / g[1] - 1) < 1e-3, "blue/green %g", g[2] / g[1]);

  /* too few pixels in every class: nothing to estimate, gains stay */
  drift.reset (labs, single);
  const std::vector<unsigned> few = { 10, 10, 10, 5000 };
  CHECK (!drift.update (frame_under (labs, few, {0.5, 0.5, 0.5})), "few");
  CHECK (drift.gains ()[0] == 1.0, "%g", drift.gains ()[0]);

  /* colours under gains: none is the colour itself; half the light is
   * what the sRGB curve says it is */
  for (const Lab & lab : labs)
    CHECK (delta_e (lab_under_gains (lab, {1, 1, 1}), lab) < 0.01,
        "L %g", lab.L);
  double grey[3];
  lab_to_srgb (labs[0], grey);
  const double half = linear_to_srgb (srgb_to_linear (grey[1]) * 0.5);
  const Lab darker = lab_under_gains (labs[0], {0.5, 0.5, 0.5});
  CHECK (delta_e (darker, srgb_to_lab (half, half, half)) < 0.01, "%g",
      darker.L);
  CHECK (std::fabs (linear_to_srgb (srgb_to_linear (0.3)) - 0.3) < 1e-12,
      "round trip");
  return corecheck_summary ();
}
