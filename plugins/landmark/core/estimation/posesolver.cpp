/* Robot pose from landmark observations: see posesolver.h and
 * docs/positioning.md. */
#include "posesolver.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/core.hpp>

namespace landmark {

namespace {

constexpr double kPi = 3.14159265358979323846;
/* the smallest sigmas used as weights, so a zero never means infinite
 * confidence: a tenth of ipmrange's smallest on rendered clips (0.3 mm and
 * 0.1 mrad for large near blobs, docs/ranging.md), so that they never
 * replace a stated sigma (at 2 mm and 0.5 mrad they did for most whole
 * blobs, and weighted range against bearing by the floors' ratio) */
constexpr double kMinRangeSigma = 0.0002;
constexpr double kMinBearingSigma = 0.00005;
/* below this angle (radians) between the lines of sight to two landmarks
 * the two-circle intersection is ill-conditioned */
const double kSinDegenerate = std::sin (10.0 * kPi / 180.0);

/* one-sigma position error of an observation, metres */
double
position_sigma_of (const RangeBearing & o)
{
  return std::hypot (o.range_sigma_used (),
      o.range () * o.bearing_sigma_used ());
}

void
copy_cov (const cv::Matx33d & m, double cov[9])
{
  for (int r = 0; r < 3; r++)
    for (int c = 0; c < 3; c++)
      cov[r * 3 + c] = m (r, c);
}

/* Unrefined two-circle solution: up to two candidates, the bearings pick
 * one and give the heading. Returns false when the circles do not meet
 * (beyond slack) or the landmarks coincide. */
bool
two_circle (const Correspondence & a, const Correspondence & b,
    double slack, Pose2 * out, Geometry * geometry, std::string * why)
{
  const double r1 = a.obs.range (), r2 = b.obs.range ();
  const double ex = b.lx - a.lx, ey = b.ly - a.ly;
  const double d = std::hypot (ex, ey);
  if (d < 1e-9) {
    *why = "the two landmarks are at the same place";
    return false;
  }
  const double ux = ex / d, uy = ey / d;   /* along the baseline */
  const double nx = -uy, ny = ux;          /* its left normal */
  double along = (r1 * r1 - r2 * r2 + d * d) / (2 * d);
  double h2 = r1 * r1 - along * along;
  double h = 0;
  if (h2 >= 0) {
    h = std::sqrt (h2);
  } else {
    /* the circles miss: outside each other or one inside the other */
    const double gap_out = d - r1 - r2;
    const double gap_in1 = r1 - r2 - d;   /* L2 inside circle 1 */
    const double gap_in2 = r2 - r1 - d;   /* L1 inside circle 2 */
    const double gap = std::max (gap_out, std::max (gap_in1, gap_in2));
    if (gap > slack) {
      *why = "the range circles do not meet (miss by " +
          std::to_string (gap) + " m)";
      return false;
    }
    if (gap == gap_out)
      along = r1 + gap / 2;
    else if (gap == gap_in1)
      along = r1 - gap / 2;
    else
      along = -(r1 + gap / 2);
  }
  double best_inconsistency = std::numeric_limits<double>::infinity ();
  for (int sign = -1; sign <= 1; sign += 2) {
    Pose2 p;
    p.x = a.lx + along * ux + sign * h * nx;
    p.y = a.ly + along * uy + sign * h * ny;
    const double h1 = std::atan2 (a.ly - p.y, a.lx - p.x) - a.obs.bearing ();
    const double h2b = std::atan2 (b.ly - p.y, b.lx - p.x) - b.obs.bearing ();
    const double diff = wrap_angle (h2b - h1);
    p.heading = wrap_angle (h1 + diff / 2);
    if (std::fabs (diff) < best_inconsistency) {
      best_inconsistency = std::fabs (diff);
      *out = p;
    }
    if (h == 0)
      break;
  }
  /* the angle between the lines of sight */
  const double v1x = a.lx - out->x, v1y = a.ly - out->y;
  const double v2x = b.lx - out->x, v2y = b.ly - out->y;
  const double n1 = std::hypot (v1x, v1y), n2 = std::hypot (v2x, v2y);
  *geometry = Geometry::Ok;
  if (n1 > 1e-9 && n2 > 1e-9) {
    const double sin_t = std::fabs (v1x * v2y - v1y * v2x) / (n1 * n2);
    const double cos_t = (v1x * v2x + v1y * v2y) / (n1 * n2);
    if (sin_t < kSinDegenerate)
      *geometry = cos_t < 0 ? Geometry::RobotOnBaseline :
          Geometry::RobotInLine;
  }
  return true;
}

/* position residuals, metres, of every correspondence */
void
fill_residuals (const std::vector<Correspondence> & cs, PoseSolution * s)
{
  s->residuals.resize (cs.size ());
  double sum = 0;
  int n = 0;
  for (size_t i = 0; i < cs.size (); i++) {
    s->residuals[i] = correspondence_residual (s->pose, cs[i]);
    if (i < s->inlier.size () && s->inlier[i]) {
      sum += s->residuals[i] * s->residuals[i];
      n++;
    }
  }
  s->residual = n ? std::sqrt (sum / n) : 0;
}

double
inlier_gate_of (const Correspondence & c, double gate)
{
  return std::max (gate, 3 * position_sigma_of (c.obs));
}

}  // namespace

double
RangeBearing::range () const
{
  return std::hypot (gx, gy);
}

double
RangeBearing::range_sigma_used () const
{
  const double s = range_sigma > 0 ? range_sigma :
      default_range_sigma (range ());
  return std::max (s, kMinRangeSigma);
}

double
RangeBearing::bearing_sigma_used () const
{
  const double s = bearing_sigma > 0 ? bearing_sigma :
      default_bearing_sigma ();
  return std::max (s, kMinBearingSigma);
}

double
RangeBearing::bearing () const
{
  return std::atan2 (gy, gx);
}

const char *
geometry_name (Geometry g)
{
  switch (g) {
    case Geometry::CollinearLandmarks:
      return "collinear-landmarks";
    case Geometry::RobotOnBaseline:
      return "robot-on-baseline";
    case Geometry::RobotInLine:
      return "robot-in-line";
    case Geometry::Ok:
      break;
  }
  return "ok";
}

const char *
matched_by_name (MatchedBy m)
{
  /* in the enum's order */
  static const char *const names[] = { "", "pose", "colour", "prior" };
  return names[(int) m];
}

double
default_range_sigma (double range)
{
  return 0.01 + 0.02 * range;
}

double
default_bearing_sigma ()
{
  return 0.01;
}

double
wrap_angle (double a)
{
  a = std::fmod (a + kPi, 2 * kPi);
  if (a <= 0)
    a += 2 * kPi;
  return a - kPi;
}

void
world_to_robot (const Pose2 & pose, double lx, double ly, double *gx,
    double *gy)
{
  const double dx = lx - pose.x, dy = ly - pose.y;
  const double c = std::cos (pose.heading), s = std::sin (pose.heading);
  *gx = c * dx + s * dy;
  *gy = -s * dx + c * dy;
}

void
robot_to_world (const Pose2 & pose, double gx, double gy, double *wx,
    double *wy)
{
  const double c = std::cos (pose.heading), s = std::sin (pose.heading);
  *wx = pose.x + c * gx - s * gy;
  *wy = pose.y + s * gx + c * gy;
}

double
correspondence_residual (const Pose2 & pose, const Correspondence & c)
{
  double gx, gy;
  world_to_robot (pose, c.lx, c.ly, &gx, &gy);
  return std::hypot (gx - c.obs.gx, gy - c.obs.gy);
}

PoseSolution
solve_one (const Correspondence & c, double heading, double heading_sigma)
{
  PoseSolution s;
  s.solver = "one";
  const double rho = c.obs.range (), psi = c.obs.bearing ();
  const double th = heading + psi;   /* world direction to the landmark */
  s.pose.x = c.lx - rho * std::cos (th);
  s.pose.y = c.ly - rho * std::sin (th);
  s.pose.heading = wrap_angle (heading);
  /* J with respect to (range, bearing, heading) */
  const cv::Matx33d J (-std::cos (th), rho * std::sin (th), rho * std::sin (th),
      -std::sin (th), -rho * std::cos (th), -rho * std::cos (th),
      0, 0, 1);
  const double sr = c.obs.range_sigma_used ();
  const double sb = c.obs.bearing_sigma_used ();
  const double sh = std::max (heading_sigma, 1e-6);
  const cv::Matx33d S (sr * sr, 0, 0, 0, sb * sb, 0, 0, 0, sh * sh);
  copy_cov (J * S * J.t (), s.cov);
  s.inlier = { true };
  fill_residuals ({c}, &s);
  s.ok = true;
  return s;
}

bool
refine_pose (const std::vector<Correspondence> & cs, Pose2 * pose,
    double cov[9], double huber_k, int max_iterations)
{
  if (cs.empty ())
    return false;
  Pose2 p = *pose;
  cv::Matx33d H;
  double chi2 = 0;
  for (int it = 0; it <= max_iterations; it++) {
    H = cv::Matx33d::zeros ();
    cv::Vec3d g (0, 0, 0);
    chi2 = 0;
    for (const auto & c : cs) {
      const double dx = c.lx - p.x, dy = c.ly - p.y;
      const double r2 = dx * dx + dy * dy;
      if (r2 < 1e-12)
        return false;   /* the robot on a landmark: bearing undefined */
      const double r = std::sqrt (r2);
      const double sr = c.obs.range_sigma_used ();
    const double sb = c.obs.bearing_sigma_used ();
      const double er = (r - c.obs.range ()) / sr;
      const double eb = wrap_angle (std::atan2 (dy, dx) - p.heading -
          c.obs.bearing ()) / sb;
      const cv::Vec3d jr (-dx / r / sr, -dy / r / sr, 0);
      const cv::Vec3d jb (dy / r2 / sb, -dx / r2 / sb, -1 / sb);
      /* Huber weights */
      const double wr = std::fabs (er) <= huber_k ? 1 :
          huber_k / std::fabs (er);
      const double wb = std::fabs (eb) <= huber_k ? 1 :
          huber_k / std::fabs (eb);
      H += wr * jr * jr.t () + wb * jb * jb.t ();
      g += wr * er * jr + wb * eb * jb;
      chi2 += er * er + eb * eb;
    }
    if (it == max_iterations)
      break;
    cv::Vec3d step;
    if (!cv::solve (H, -g, step, cv::DECOMP_CHOLESKY))
      return false;
    p.x += step[0];
    p.y += step[1];
    p.heading = wrap_angle (p.heading + step[2]);
    if (std::fabs (step[0]) + std::fabs (step[1]) < 1e-10
        && std::fabs (step[2]) < 1e-12) {
      max_iterations = it + 1;   /* one more pass for H at the solution */
    }
  }
  cv::Matx33d C;
  if (cv::invert (H, C, cv::DECOMP_SVD) == 0 || !std::isfinite (C (0, 0)))
    return false;
  /* scale by the a posteriori variance factor when it shows the sigmas
   * were too small */
  const int dof = 2 * (int) cs.size () - 3;
  if (dof > 0)
    C *= std::max (1.0, chi2 / dof);
  *pose = p;
  copy_cov (C, cov);
  return true;
}

PoseSolution
solve_two (const Correspondence & a, const Correspondence & b, double slack)
{
  PoseSolution s;
  s.solver = "two";
  Pose2 p;
  if (!two_circle (a, b, slack, &p, &s.geometry, &s.why))
    return s;
  s.pose = p;
  const std::vector<Correspondence> cs = { a, b };
  if (!refine_pose (cs, &s.pose, s.cov, 1e9, 20)) {
    s.why = "the two-landmark geometry is singular";
    return s;
  }
  s.inlier = { true, true };
  fill_residuals (cs, &s);
  s.ok = true;
  return s;
}

bool
landmarks_collinear (const std::vector<Correspondence> & cs, double tol)
{
  if (cs.size () < 3)
    return false;
  double mx = 0, my = 0;
  for (const auto & c : cs) {
    mx += c.lx;
    my += c.ly;
  }
  mx /= cs.size ();
  my /= cs.size ();
  double sxx = 0, syy = 0, sxy = 0;
  for (const auto & c : cs) {
    sxx += (c.lx - mx) * (c.lx - mx);
    syy += (c.ly - my) * (c.ly - my);
    sxy += (c.lx - mx) * (c.ly - my);
  }
  const double tr = sxx + syy;
  const double det = sxx * syy - sxy * sxy;
  const double disc = std::sqrt (std::max (0.0, tr * tr / 4 - det));
  const double lmax = tr / 2 + disc, lmin = std::max (0.0, tr / 2 - disc);
  return lmax <= 0 || std::sqrt (lmin / lmax) < tol;
}

PoseSolution
solve_many (const std::vector<Correspondence> & cs, const LsqOptions & opt)
{
  PoseSolution s;
  s.solver = "lsq";
  const size_t n = cs.size ();
  if (n < 3) {
    s.why = "the least-squares solver needs three or more landmarks";
    return s;
  }
  /* consensus: every pair's two-circle pose, scored on all */
  bool have = false;
  int best_inliers = -1;
  double best_cost = 0;
  Pose2 best;
  for (size_t i = 0; i < n; i++) {
    for (size_t j = i + 1; j < n; j++) {
      Pose2 p;
      Geometry g;
      std::string why;
      if (!two_circle (cs[i], cs[j], opt.inlier_gate, &p, &g, &why))
        continue;
      int inliers = 0;
      double cost = 0;
      for (size_t k = 0; k < n; k++) {
        const double r = correspondence_residual (p, cs[k]);
        const double gate = inlier_gate_of (cs[k], opt.inlier_gate);
        if (r <= gate)
          inliers++;
        cost += std::min (r * r, gate * gate);
      }
      if (!have || inliers > best_inliers ||
          (inliers == best_inliers && cost < best_cost)) {
        have = true;
        best_inliers = inliers;
        best_cost = cost;
        best = p;
      }
    }
  }
  if (!have) {
    s.why = "no pair of landmarks gives a solution";
    return s;
  }
  s.pose = best;
  s.inlier.assign (n, false);
  for (int pass = 0; pass < 3; pass++) {
    std::vector<Correspondence> used;
    std::vector<bool> inl (n, false);
    for (size_t k = 0; k < n; k++) {
      if (correspondence_residual (s.pose, cs[k]) <=
          inlier_gate_of (cs[k], opt.inlier_gate)) {
        inl[k] = true;
        used.push_back (cs[k]);
      }
    }
    if (used.size () < 2) {
      s.why = "fewer than two landmarks agree";
      return s;
    }
    if (pass > 0 && inl == s.inlier)
      break;
    s.inlier = inl;
    Pose2 p = s.pose;
    if (!refine_pose (used, &p, s.cov, opt.huber_k, opt.max_iterations)) {
      s.why = "the landmark geometry is singular";
      return s;
    }
    s.pose = p;
  }
  std::vector<Correspondence> used;
  for (size_t k = 0; k < n; k++)
    if (s.inlier[k])
      used.push_back (cs[k]);
  if (used.size () == 2) {
    /* only two agree: the two-landmark solution, with its geometry */
    PoseSolution two = solve_two (used[0], used[1], opt.inlier_gate);
    if (!two.ok) {
      s.why = two.why;
      return s;
    }
    two.inlier = s.inlier;
    fill_residuals (cs, &two);
    return two;
  }
  if (landmarks_collinear (used))
    s.geometry = Geometry::CollinearLandmarks;
  fill_residuals (cs, &s);
  s.ok = true;
  return s;
}

/* ---- association --------------------------------------------------- */

namespace {

/* one-to-one: where two detections took one landmark, the nearer keeps
 * it */
void
resolve_conflicts (std::vector<int> * match, const std::vector<double> & dist,
    std::vector<std::string> * reason)
{
  for (size_t i = 0; i < match->size (); i++) {
    if ((*match)[i] < 0)
      continue;
    for (size_t j = i + 1; j < match->size (); j++) {
      if ((*match)[j] != (*match)[i])
        continue;
      const size_t loser = dist[i] <= dist[j] ? j : i;
      (*match)[loser] = -1;
      (*reason)[loser] = "duplicate";
      if (loser == i)
        break;
    }
  }
}

}  // namespace

LocaliseResult
localise (const std::vector<MapPoint> & map,
    const std::vector<Detection> & dets, const LocaliseOptions & opt)
{
  LocaliseResult res;
  const size_t nd = dets.size ();
  res.match.assign (nd, -1);
  res.matched_by.assign (nd, MatchedBy::None);
  res.residual.assign (nd, std::numeric_limits<double>::quiet_NaN ());
  std::vector<std::string> reason (nd);
  std::vector<std::vector<int>> cand (nd);
  for (size_t i = 0; i < nd; i++) {
    const Detection & d = dets[i];
    std::vector<int> same_marker;
    for (size_t m = 0; m < map.size (); m++) {
      if (map[m].class_name != d.class_name)
        continue;
      cand[i].push_back ((int) m);
      if (d.has_marker && map[m].ball == d.marker_ball
          && std::fabs (map[m].z - d.marker_z) < 1e-6
          && std::fabs (map[m].diameter - d.marker_diameter) < 1e-6)
        same_marker.push_back ((int) m);
    }
    /* a range made for one kind of marker fits only landmarks of that
     * kind; if none has it (another map upstream), the class decides */
    if (!same_marker.empty ())
      cand[i] = std::move (same_marker);
    if (cand[i].empty ())
      reason[i] = "no-landmark-of-class";
  }

  std::vector<int> match (nd, -1);
  std::vector<double> dist (nd, std::numeric_limits<double>::infinity ());
  bool gated = false;
  if (opt.have_prior) {
    gated = true;
    for (size_t i = 0; i < nd; i++) {
      if (cand[i].empty ())
        continue;
      if (cand[i].size () == 1) {
        /* a colour seen once on the map: the class decides (the solvers'
         * consensus rejects it if it is wrong) */
        match[i] = cand[i][0];
        double wx, wy;
        robot_to_world (opt.prior, dets[i].obs.gx, dets[i].obs.gy, &wx, &wy);
        dist[i] = std::hypot (wx - map[match[i]].x, wy - map[match[i]].y);
        continue;
      }
      double wx, wy;
      robot_to_world (opt.prior, dets[i].obs.gx, dets[i].obs.gy, &wx, &wy);
      const double gate = std::max (opt.gate,
          3 * position_sigma_of (dets[i].obs));
      for (int m : cand[i]) {
        const double dd = std::hypot (wx - map[m].x, wy - map[m].y);
        if (dd <= gate && dd < dist[i]) {
          dist[i] = dd;
          match[i] = m;
        }
      }
      if (match[i] < 0)
        reason[i] = "outside-gate";
    }
    resolve_conflicts (&match, dist, &reason);
  }

  int n_cand = 0, n_match = 0;
  for (size_t i = 0; i < nd; i++) {
    n_cand += !cand[i].empty ();
    n_match += match[i] >= 0;
  }
  /* without a prior, or when the gate lost landmarks (a stale or wrong
   * prior): associate by consensus over pairs, kept when it places more */
  bool by_consensus = false;
  if ((!gated || n_match < n_cand) && n_cand >= 2) {
    bool have = false, ambiguous = false;
    int best_in = -1;
    double best_cost = 0;
    Pose2 best;
    std::vector<int> best_assign, assign (nd);
    /* seeds: detections with candidates, the most precise first */
    std::vector<size_t> seeds;
    for (size_t i = 0; i < nd; i++)
      if (!cand[i].empty ())
        seeds.push_back (i);
    std::stable_sort (seeds.begin (), seeds.end (), [&](size_t x, size_t y) {
          return position_sigma_of (dets[x].obs) <
              position_sigma_of (dets[y].obs);
        });
    int &tried = res.hypotheses;
    const int budget = kMaxConsensusHypotheses;
    for (size_t si = 0; si < seeds.size () && tried < budget; si++)
      for (size_t sj = si + 1; sj < seeds.size () && tried < budget; sj++)
        for (size_t ai = 0; ai < cand[seeds[si]].size () && tried < budget;
            ai++)
          for (size_t bi = 0; bi < cand[seeds[sj]].size () && tried < budget;
              bi++) {
            const size_t i = seeds[si], j = seeds[sj];
            const int a = cand[i][ai], b = cand[j][bi];
            if (a == b)
              continue;
            tried++;
            Correspondence ca { dets[i].obs, map[a].x, map[a].y };
            Correspondence cb { dets[j].obs, map[b].x, map[b].y };
            Pose2 p;
            Geometry g;
            std::string why;
            if (!two_circle (ca, cb, opt.lsq.inlier_gate, &p, &g, &why))
              continue;
            int in = 0;
            double cost = 0;
            for (size_t k = 0; k < nd; k++) {
              double rmin = std::numeric_limits<double>::infinity ();
              Correspondence ck { dets[k].obs, 0, 0 };
              const double gate = inlier_gate_of (ck, opt.lsq.inlier_gate);
              assign[k] = -1;
              for (int m : cand[k]) {
                ck.lx = map[m].x;
                ck.ly = map[m].y;
                const double r = correspondence_residual (p, ck);
                if (r < rmin) {
                  rmin = r;
                  if (r <= gate)
                    assign[k] = m;
                }
              }
              if (cand[k].empty ())
                continue;
              in += rmin <= gate;
              cost += std::min (rmin * rmin, gate * gate);
            }
            /* as many agree with another assignment: ambiguous */
            if (have && in == best_in && assign != best_assign)
              ambiguous = true;
            if (!have || in > best_in || (in == best_in && cost < best_cost)) {
              if (have && in > best_in)
                ambiguous = false;
              have = true;
              best_in = in;
              best_cost = cost;
              best = p;
              best_assign = assign;
            }
          }
    if (have && !ambiguous && (!gated || best_in > n_match)) {
      std::fill (match.begin (), match.end (), -1);
      std::fill (dist.begin (), dist.end (),
          std::numeric_limits<double>::infinity ());
      for (size_t k = 0; k < nd; k++) {
        if (cand[k].empty ())
          continue;
        Correspondence ck { dets[k].obs, 0, 0 };
        const double gate = inlier_gate_of (ck, opt.lsq.inlier_gate);
        for (int m : cand[k]) {
          ck.lx = map[m].x;
          ck.ly = map[m].y;
          const double r = correspondence_residual (best, ck);
          if (r <= gate && r < dist[k]) {
            dist[k] = r;
            match[k] = m;
          }
        }
        reason[k] = match[k] < 0 ? "outlier" : "";
      }
      resolve_conflicts (&match, dist, &reason);
      by_consensus = true;
    }
  }
  if (!gated && !by_consensus) {
    /* no prior and nothing agrees: keep unambiguous detections only */
    for (size_t k = 0; k < nd; k++) {
      if (cand[k].size () == 1)
        match[k] = cand[k][0];
      else if (cand[k].size () > 1)
        reason[k] = "ambiguous";
    }
  }

  std::vector<Correspondence> cs;
  std::vector<size_t> det_of;
  for (size_t k = 0; k < nd; k++) {
    if (match[k] < 0)
      continue;
    cs.push_back ({ dets[k].obs, map[match[k]].x, map[match[k]].y });
    det_of.push_back (k);
  }

  res.paired = match;
  PoseSolution sol;
  if (cs.size () >= 3) {
    sol = solve_many (cs, opt.lsq);
  } else if (cs.size () == 2) {
    sol = solve_two (cs[0], cs[1], opt.lsq.inlier_gate);
  } else if (cs.size () == 1 && opt.have_heading) {
    sol = solve_one (cs[0], opt.heading, opt.heading_sigma);
  } else {
    /* no pose to check them: the colour names a landmark the map holds
     * once; a repeated colour is named only where the prior placed it */
    res.why = "too-few-landmarks";
    for (size_t k = 0; k < nd; k++) {
      if (match[k] < 0)
        continue;
      if (cand[k].size () == 1)
        res.matched_by[k] = MatchedBy::Colour;
      else if (gated && !by_consensus)
        res.matched_by[k] = MatchedBy::Prior;
      else
        reason[k] = "too-few-landmarks";
      if (res.matched_by[k] != MatchedBy::None)
        res.match[k] = match[k];
    }
    res.reasons = reason;
    return res;
  }
  res.solution = sol;
  if (!sol.ok) {
    res.why = "no-solution";
    for (size_t k = 0; k < nd; k++)
      if (match[k] >= 0)
        reason[k] = "no-solution";
    res.reasons = reason;
    return res;
  }
  res.ok = true;
  for (size_t c = 0; c < cs.size (); c++) {
    const size_t k = det_of[c];
    res.residual[k] = sol.residuals[c];
    if (sol.inlier[c]) {
      res.match[k] = match[k];
      res.matched_by[k] = MatchedBy::Pose;
      res.n_used++;
    } else {
      reason[k] = "outlier";
    }
  }
  res.reasons = reason;
  return res;
}

}  // namespace landmark
