/* slam-bench: the cost and memory of the SLAM core (plugins/landmark/core/
 * slam.h) over a long run: 15 landmarks of five colours (each three times)
 * around a 3 m x 3 m field, a robot driving an ellipse inside it at
 * 0.3 m/s, 30 frames per second, 3,000 frames (about five laps); each frame
 * the landmarks within 3.5 m and 27 degrees of the heading (the seed's
 * 54-degree camera), ranged with 1 % and 0.002 rad of Gaussian noise, one
 * in twenty missed. No map; without --odometry the constant-velocity
 * model, with it wheel odometry of the camera's motion, 2 % long and
 * slipping 1 mm per sqrt(m) and 0.001 rad per sqrt(m) (the filter states
 * 0.002 and runs its slip learning, which with the default floor keeps
 * the scale at 1 here; --stated: learning off, to show what it costs).
 *
 * Prints the CPU time of this thread per frame (median, p95, max; the first
 * and the last 300 frames apart), the resident memory after 300, 1,500 and
 * 3,000 frames, the landmarks estimated and the path error against the
 * truth in the map frame (the first pose's). It asserts nothing about
 * speed; docs/performance.md quotes it.
 *
 *   build/tests/bench/slam-bench [FRAMES] [--landmarks N]
 *       [--odometry [--stated]]
 */
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "slam.h"

using namespace landmark;

static double
thread_ms ()
{
  timespec ts;
  clock_gettime (CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

/* resident set size, kB (Linux) */
static long
rss_kb ()
{
  std::ifstream f ("/proc/self/status");
  std::string key;
  long value = -1;
  while (f >> key) {
    if (key == "VmRSS:") {
      f >> value;
      break;
    }
    f.ignore (1 << 12, '\n');
  }
  return value;
}

static double
quantile (std::vector<double> v, double q)
{
  if (v.empty ())
    return 0;
  std::sort (v.begin (), v.end ());
  return v[std::min (v.size () - 1, (size_t) (q * v.size ()))];
}

struct Truth {
  double x, y;
  std::string class_name;
};

int
main (int argc, char **argv)
{
  int frames = 3000, count = 15;
  bool odometry = false, stated = false;
  for (int a = 1; a < argc; a++) {
    if (std::string (argv[a]) == "--odometry")
      odometry = true;
    else if (std::string (argv[a]) == "--stated")
      stated = true;
    else if (std::string (argv[a]) == "--landmarks" && a + 1 < argc)
      count = std::clamp (std::atoi (argv[++a]), 1, 128);
    else
      frames = std::max (1, std::atoi (argv[a]));
  }
  const double fps = 30, speed = 0.3, rx = 1.1, ry = 0.8;
  const double fov = 27 * M_PI / 180, max_range = 3.5;
  const char *colours[] = { "red", "green", "yellow", "pink", "blue" };
  std::mt19937 rng (20261125);
  std::normal_distribution<double> unit (0, 1);
  std::uniform_real_distribution<double> uniform (0, 1);

  /* the colours in turn, spread around the field's edge, a little off it;
   * beyond 15, on rings 0.5 m further out, about 0.4 m apart (a map of
   * up to max-landmarks, 128: what the state's size costs) */
  std::vector<Truth> field;
  for (int ring = 0, placed = 0; placed < count; ring++) {
    const double radius = 1.5 + 0.5 * ring;
    const int on_ring = ring == 0 ? std::min (count, 15)
        : std::min (count - placed, (int) (2 * M_PI * radius / 0.4));
    for (int i = 0; i < on_ring; i++, placed++) {
      const double a = 2 * M_PI * i / on_ring + 0.1 * unit (rng) / (ring + 1);
      const double r = radius + 0.1 * unit (rng);
      field.push_back ({r * std::cos (a), r * std::sin (a),
              colours[placed % 5]});
    }
  }

  Slam slam;
  slam.opt.odo_slip_adapt = !stated;
  std::vector<double> cost;
  std::vector<double> error;
  long rss[3] = { 0, 0, 0 };
  Pose2 first {}, last_truth {};
  double t = 0;
  /* the ellipse's parameter advances so that the robot keeps its speed */
  double phase = 0;
  for (int f = 0; f < frames; f++) {
    const double dx = -rx * std::sin (phase), dy = ry * std::cos (phase);
    const Pose2 truth {rx * std::cos (phase), ry * std::sin (phase),
      std::atan2 (dy, dx)};
    if (f == 0)
      first = truth;
    std::vector<SlamObservation> obs;
    for (const Truth & m : field) {
      const double wx = m.x - truth.x, wy = m.y - truth.y;
      const double c = std::cos (truth.heading), s = std::sin (truth.heading);
      const double gx = c * wx + s * wy, gy = -s * wx + c * wy;
      const double range = std::hypot (gx, gy), bearing = std::atan2 (gy, gx);
      if (range > max_range || range < 0.3 || std::fabs (bearing) > fov
          || uniform (rng) < 0.05)
        continue;
      const double r = range * (1 + 0.01 * unit (rng));
      const double b = bearing + 0.002 * unit (rng);
      SlamObservation o;
      o.class_name = m.class_name;
      o.obs.gx = r * std::cos (b);
      o.obs.gy = r * std::sin (b);
      o.obs.range_sigma = 0.01 * range;
      o.obs.bearing_sigma = 0.002;
      o.marker_diameter = 0.1;
      obs.push_back (o);
    }
    /* the increment since the last frame in its robot frame, with the
     * odometry's errors */
    double odo[3] = { 0, 0, 0 };
    if (odometry && f > 0) {
      const double c = std::cos (last_truth.heading),
          s = std::sin (last_truth.heading);
      const double wx = truth.x - last_truth.x, wy = truth.y - last_truth.y;
      const double d = std::hypot (wx, wy);
      odo[0] = 1.02 * (c * wx + s * wy) + 0.001 * std::sqrt (d) * unit (rng);
      odo[1] = 1.02 * (-s * wx + c * wy) + 0.001 * std::sqrt (d)
          * unit (rng);
      odo[2] = std::remainder (truth.heading - last_truth.heading,
          2 * M_PI) + 0.001 * std::sqrt (d) * unit (rng);
    }
    last_truth = truth;
    const double t0 = thread_ms ();
    if (f > 0 && odometry)
      slam.predict_odometry (odo[0], odo[1], odo[2], 1 / fps);
    else if (f > 0)
      slam.predict (1 / fps);
    const SlamFrame out = slam.update (obs);
    cost.push_back (thread_ms () - t0);
    if (out.ok) {
      /* the truth in the map frame: relative to the first pose */
      const double c = std::cos (first.heading), s = std::sin (first.heading);
      const double wx = truth.x - first.x, wy = truth.y - first.y;
      const Pose2 p = slam.pose ();
      error.push_back (std::hypot (p.x - (c * wx + s * wy),
              p.y - (-s * wx + c * wy)));
    }
    if (f + 1 == 300)
      rss[0] = rss_kb ();
    if (f + 1 == 1500)
      rss[1] = rss_kb ();
    if (f + 1 == frames)
      rss[2] = rss_kb ();
    phase += speed / fps / std::hypot (dx, dy);
    t += 1 / fps;
  }

  int confirmed = 0;
  for (const SlamLandmark & l : slam.landmarks ())
    confirmed += l.confirmed;
  const size_t tail = std::min<size_t> (300, cost.size ());
  const std::vector<double> head (cost.begin (), cost.begin () + tail);
  const std::vector<double> last (cost.end () - tail, cost.end ());
  std::printf ("slam-bench: %d frames (%.0f s, %.1f laps), %d landmarks, "
      "no map, %s", frames, t, phase / (2 * M_PI), count, odometry ? "odometry"
      : "no odometry\n");
  if (odometry)
    std::printf (" (slip %s, scale %.2f)\n", stated ? "as stated" : "learnt",
        slam.odometry_slip_scale ());
  std::printf ("cost per frame, CPU ms: median %.3f, p95 %.3f, max %.3f; "
      "first 300: median %.3f; last 300: median %.3f, p95 %.3f\n",
      quantile (cost, 0.5), quantile (cost, 0.95), quantile (cost, 1.0),
      quantile (head, 0.5), quantile (last, 0.5), quantile (last, 0.95));
  std::printf ("resident memory, kB: %ld after 300 frames, %ld after 1500, "
      "%ld after %d\n", rss[0], rss[1], rss[2], frames);
  std::printf ("landmarks: %zu estimated, %d confirmed; path error in the "
      "map frame: median %.1f cm, p95 %.1f cm over %zu frames with a pose\n",
      slam.landmarks ().size (), confirmed, 100 * quantile (error, 0.5),
      100 * quantile (error, 0.95), error.size ());
  return 0;
}
