/* floorprofile-bench: the cost of the floor profile core
 * (plugins/landmark/core/geometry/floorprofile.h) on the 640x480 label plane of two
 * ray-cast boxes (tests/core/floorscene.h): configuring once, then the
 * median and 90th percentile of 500 scans, in CPU time of this thread (the
 * machine may be shared; wall-clock time would count the time other
 * processes hold the core). It prints numbers (docs/floorboundary.md
 * quotes them) and asserts nothing about speed. */
#include "floorscene.h"

#include <algorithm>
#include <cstdio>
#include <ctime>

static double
thread_ms ()
{
  timespec ts;
  clock_gettime (CLOCK_THREAD_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec / 1e6;
}

int
main ()
{
  const CameraGeometry g = camera ();
  FloorProfileParams fp;
  FloorProfile prof;
  std::string err;
  const double t0 = thread_ms ();
  if (!prof.configure (g, fp, &err)) {
    std::fprintf (stderr, "floorprofile-bench: %s\n", err.c_str ());
    return 1;
  }
  const double t1 = thread_ms ();
  LabelRole r[256];
  roles (r);
  std::vector<uint8_t> plane = render ({{1.5, -0.3, 0.2, 0.4, 0.5},
      {2.5, 0.4, 0.9, 0.3, 0.3}});
  const int n = 500;
  for (int i = 0; i < 10; i++)
    prof.scan (plane.data (), W, r);
  std::vector<double> t (n);
  for (int i = 0; i < n; i++) {
    const double a = thread_ms ();
    prof.scan (plane.data (), W, r);
    t[i] = thread_ms () - a;
  }
  std::sort (t.begin (), t.end ());
  std::printf ("configure %.1f ms; scan of a 640x480 plane: median %.3f ms, "
      "p90 %.3f ms (thread CPU time)\n", t1 - t0, t[n / 2], t[n * 9 / 10]);
  return corecheck::failures ? 1 : 0;
}
