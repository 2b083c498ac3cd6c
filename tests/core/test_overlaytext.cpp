/* The overlay's pose line says the pose it was given: its text against
 * strings written out by hand (headings converted from radians here:
 * 2 rad = 114.59 degrees). */
#include <cmath>
#include <cstring>

#include "corecheck.h"
#include "overlaydraw.h"

using landmark::overlay::Pose;

static void
check_text (double x, double y, double heading, bool compact,
    const char *want)
{
  Pose p;
  p.x = x;
  p.y = y;
  p.heading = heading;
  char got[128];
  landmark::overlay::pose_line_text (p, compact, got, sizeof (got));
  CHECK (std::strcmp (got, want) == 0, "pose (%g, %g, %g)%s: \"%s\", "
      "want \"%s\"", x, y, heading, compact ? " compact" : "", got, want);
}

int
main ()
{
  check_text (1.25, -3.5, 2.0, false,
      "pose x 1.250 m  y -3.500 m  heading 114.6 deg");
  check_text (1.25, -3.5, 2.0, true, "1.25 -3.50 115d");
  check_text (0.0, 0.0, -M_PI / 2, false,
      "pose x 0.000 m  y 0.000 m  heading -90.0 deg");
  check_text (0.0, 0.0, -M_PI / 2, true, "0.00 0.00 -90d");
  check_text (12.3456, 7.0, M_PI, false,
      "pose x 12.346 m  y 7.000 m  heading 180.0 deg");
  check_text (-0.004, 2.0, 0.5 * M_PI / 180, false,
      "pose x -0.004 m  y 2.000 m  heading 0.5 deg");
  return corecheck_summary ();
}
