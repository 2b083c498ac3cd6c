/* The landmark SLAM filter's data association (slam.h): each detection
 * gated against each landmark of its class, the jointly compatible set of
 * pairings (JCBB), and the relocalisation of a lost pose on two or more
 * detections matched by their mutual distances. */
#include "slam.h"
#include "slaminternal.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <functional>
#include <limits>
#include <unordered_map>
#include <utility>

namespace landmark {

namespace {

/* regularised lower incomplete gamma P(a, x), by its series */
double
gamma_p (double a, double x)
{
  if (x <= 0)
    return 0;
  double term = 1.0 / a, sum = term;
  for (int n = 1; n < 1000; n++) {
    term *= x / (a + n);
    sum += term;
    if (term < sum * 1e-15)
      break;
  }
  return std::min (1.0, std::exp (-x + a * std::log (x) - std::lgamma (a))
      * sum);
}

/* P(X >= x) for X Poisson with mean lambda, summed upward (the tail is
 * tiny where it matters, and 1 - cdf would lose it) */
double
poisson_tail (double lambda, int x)
{
  if (x <= 0)
    return 1;
  double term = std::exp (-lambda);
  for (int k = 1; k <= x; k++)
    term *= lambda / k;
  double sum = 0;
  for (int k = x; k < x + 200 && term > 1e-300; k++) {
    sum += term;
    term *= lambda / (k + 1);
  }
  return std::min (1.0, sum);
}

}  // namespace

double
chi2_quantile (double p, int dof)
{
  double lo = 0, hi = 10.0 * dof + 100;
  for (int i = 0; i < 200; i++) {
    const double mid = 0.5 * (lo + hi);
    if (gamma_p (0.5 * dof, 0.5 * mid) < p)
      lo = mid;
    else
      hi = mid;
  }
  return 0.5 * (lo + hi);
}

/* The pairing of observation i with landmark k, its Jacobian and P H'
 * taken from P (the state's covariance); false when the landmark is at
 * the pose. */
bool
Slam::make_pairing (const std::vector<SlamObservation> & obs, int i, int k,
    const cv::Mat & P, Pairing * pr) const
{
  const auto & o = obs[i];
  const SlamLandmark & l = lm_[k];
  const int sl = slot_[k];
  const double lx = sl >= 0 ? s_[sl] : l.x, ly = sl >= 0 ? s_[sl + 1] : l.y;
  const double dx = lx - s_[0], dy = ly - s_[1];
  const double q = dx * dx + dy * dy;
  if (q < 1e-12)
    return false;
  const double r = std::sqrt (q);
  const double zr = o.obs.range (), zb = o.obs.bearing ();
  double sr, sb;
  slam_observation_sigmas (o, pass_views_[k] + 1, &sr, &sb);
  pr->obs = i;
  pr->lm = k;
  /* bearing innovation wrapped: a landmark behind the robot is near
   * +-pi and must not look 2 pi away */
  pr->nu = cv::Vec2d (zr - r, wrap_angle (zb -
          wrap_angle (std::atan2 (dy, dx) - s_[2])));
  pr->H = cv::Mat::zeros (2, (int) n (), CV_64F);
  double *h0 = pr->H.ptr<double> (0), *h1 = pr->H.ptr<double> (1);
  h0[0] = -dx / r;
  h0[1] = -dy / r;
  h1[0] = dy / q;
  h1[1] = -dx / q;
  h1[2] = -1;
  pr->cols[0] = 0;
  pr->cols[1] = 1;
  pr->cols[2] = 2;
  pr->n_cols = 3;
  if (sl >= 0) {
    pr->cols[pr->n_cols++] = sl;
    pr->cols[pr->n_cols++] = sl + 1;
    h0[sl] = dx / r;
    h0[sl + 1] = dy / r;
    h1[sl] = -dy / q;
    h1[sl + 1] = dx / q;
  }
  /* the slow error: a state once the landmark carries it, else in R as
   * the white part is (the same distribution: it is still uncorrelated) */
  const int bs = bias_slot_[k];
  const double white = bs >= 0 ? 1 - opt.meas_slow_share : 1;
  if (bs >= 0) {
    pr->cols[pr->n_cols++] = bs;
    pr->cols[pr->n_cols++] = bs + 1;
    h0[bs] = sr;
    h1[bs + 1] = sb;
  }
  pr->R = cv::Matx22d (white * sr * sr, 0, 0, white * sb * sb);
  pr->PHt = jacobian_times (pr->H, P).t ();
  cv::Mat S = pr->H * pr->PHt + cv::Mat (pr->R);
  cv::Mat nu (pr->nu);
  cv::Mat d = nu.t () * S.inv (cv::DECOMP_CHOLESKY) * nu;
  pr->d2 = d.at<double> (0);
  return true;
}

/* Per observation, the pairings with landmarks of its class within the
 * gate (opt.gate_chi2), nearest first. */
void
Slam::gate_pairings (const std::vector<SlamObservation> & obs,
    const cv::Mat & P, std::vector<std::vector<Pairing>> & cand) const
{
  for (size_t i = 0; i < obs.size (); i++) {
    for (size_t k = 0; k < lm_.size (); k++) {
      if (lm_[k].class_name != obs[i].class_name)
        continue;
      Pairing pr;
      if (!make_pairing (obs, (int) i, (int) k, P, &pr))
        continue;
      if (pr.d2 < opt.gate_chi2)
        cand[i].push_back (std::move (pr));
    }
    std::sort (cand[i].begin (), cand[i].end (),
        [](const Pairing & a, const Pairing & b) { return a.d2 < b.d2; });
  }
}

/* The joint NIS of a set of pairings. */
double
Slam::joint_nis (const std::vector<const Pairing *> &h)
{
  const int m = (int) h.size ();
  cv::Mat S (2 * m, 2 * m, CV_64F), nu (2 * m, 1, CV_64F);
  for (int a = 0; a < m; a++) {
    nu.at<double> (2 * a) = h[a]->nu[0];
    nu.at<double> (2 * a + 1) = h[a]->nu[1];
    const Pairing & pa = *h[a];
    for (int b = 0; b < m; b++) {
      /* H_a P H_b^T over H_a's non-zero columns */
      for (int r = 0; r < 2; r++)
        for (int c = 0; c < 2; c++) {
          double v = a == b ? pa.R (r, c) : 0;
          for (int t = 0; t < pa.n_cols; t++)
            v += pa.H.at<double> (r, pa.cols[t])
                * h[b]->PHt.at<double> (pa.cols[t], c);
          S.at<double> (2 * a + r, 2 * b + c) = v;
        }
    }
  }
  cv::Mat d = nu.t () * S.inv (cv::DECOMP_CHOLESKY) * nu;
  return d.at<double> (0);
}

/* JCBB over the gated pairings: into best the most pairings whose joint
 * NIS passes the chi-square test, then the least joint NIS; returns it. */
double
Slam::jcbb (const std::vector<std::vector<Pairing>> & cand,
    std::vector<const Pairing *> & best)
{
  std::vector<const Pairing *> cur;
  double best_nis = 0;
  int nodes = 0;
  std::vector<bool> used (lm_.size (), false);
  /* the joint gate for m pairings, kept while the probability stays */
  if (joint_gate_p_ != opt.joint_probability) {
    joint_gate_.assign (1, 0);
    joint_gate_p_ = opt.joint_probability;
  }
  while (joint_gate_.size () <= cand.size ())
    joint_gate_.push_back (chi2_quantile (opt.joint_probability,
            2 * (int) joint_gate_.size ()));
  const std::vector<double> & thresholds = joint_gate_;
  std::function<void (size_t, double)> search = [&](size_t i, double nis) {
    if (++nodes > opt.max_jcbb_nodes)
      return;
    if (i == cand.size ()) {
      if (cur.size () > best.size () || (cur.size () == best.size ()
              && nis < best_nis)) {
        best = cur;
        best_nis = nis;
      }
      return;
    }
    size_t remaining = 0;
    for (size_t j = i; j < cand.size (); j++)
      remaining += cand[j].empty ()? 0 : 1;
    if (cur.size () + remaining < best.size ())
      return;
    for (const Pairing & pr : cand[i]) {
      if (used[pr.lm])
        continue;
      cur.push_back (&pr);
      const double d = joint_nis (cur);
      if (d < thresholds[cur.size ()]) {
        used[pr.lm] = true;
        search (i + 1, d);
        used[pr.lm] = false;
      }
      cur.pop_back ();
    }
    /* leave detection i unpaired */
    if (cur.size () + remaining - (cand[i].empty ()? 0 : 1) >= best.size ())
      search (i + 1, nis);
  };
  search (0, 0);
  return best_nis;
}

/* A lost pose: the heading so uncertain (after a turn bridged on no
 * landmark) that the gate's bearing span, +-sqrt(gate) sigma, is the
 * whole circle. Any landmark of the colour at about the right range
 * then passes it, so a pairing carries no evidence that it is the same
 * landmark (a yellow disc never seen would pair with the one yellow
 * landmark mapped a metre away), and one linearised step from that far
 * off leaves the pose degrees wrong while its covariance says one.
 * Pair only what relocalisation on two or more landmarks finds, and
 * linearise the update at that pose. */
double
Slam::pair_relocalised (const std::vector<SlamObservation> & obs,
    const cv::Mat & P, const std::vector<double> & prior,
    std::vector<Pairing> & found, std::vector<const Pairing *> & best)
{
  Pose2 at;
  std::vector<int> assign;
  bool weak;
  if (!relocalise (obs, &at, &assign, &weak) || !reloc_confirmed (assign,
          weak))
    return 0;
  s_[0] = at.x;
  s_[1] = at.y;
  s_[2] = at.heading;
  found.reserve (obs.size ());
  for (size_t i = 0; i < obs.size (); i++) {
    Pairing pr;
    if (assign[i] >= 0 && make_pairing (obs, (int) i, assign[i], P, &pr))
      found.push_back (std::move (pr));
  }
  for (const Pairing & pr : found)
    best.push_back (&pr);
  const double best_nis = best.empty ()? 0 : joint_nis (best);
  if (best.empty ())
    s_ = prior;                 /* nothing to update with: as predicted */
  return best_nis;
}

/* A relocalisation on two detections that the given map alone supports
 * (weak) is taken once the same two landmarks have been found in
 * opt.reloc_confirm_frames consecutive frames; any other resets the count.
 * Counted once per frame. */
bool
Slam::reloc_confirmed (const std::vector<int> & assign, bool weak)
{
  RelocPending & p = reloc_pending_;
  if (!weak) {
    p = RelocPending ();
    return true;
  }
  if (p.frame == frame_no_)
    return p.frames >= opt.reloc_confirm_frames;
  int pair[2] = { -1, -1 };
  for (int k : assign)
    if (k >= 0)
      pair[pair[0] < 0 ? 0 : 1] = k;
  if (pair[0] > pair[1])
    std::swap (pair[0], pair[1]);
  if (p.frame == frame_no_ - 1 && p.lm[0] == pair[0] && p.lm[1] == pair[1])
    p.frames++;
  else
    p.frames = 1;
  p.lm[0] = pair[0];
  p.lm[1] = pair[1];
  p.frame = frame_no_;
  return p.frames >= opt.reloc_confirm_frames;
}

/* The first pose on a given map that trilaterate's solvers could not place
 * (two detections of repeated colours): relocalised from a lost pose at
 * the map's centre, its position sigma the map's extent plus the
 * detections' reach, heading sigma pi. True leaves that lost pose, for
 * update () to relocalise; false, no pose. */
bool
Slam::first_pose_relocalised (const std::vector<SlamObservation> & obs)
{
  if (lm_.size () < 2 || obs.size () < 2)
    return false;
  double cx = 0, cy = 0, reach = 0;
  for (const auto & l : lm_) {
    cx += l.x / lm_.size ();
    cy += l.y / lm_.size ();
  }
  for (const auto & l : lm_)
    reach = std::max (reach, std::hypot (l.x - cx, l.y - cy));
  for (const auto & o : obs)
    reach = std::max (reach, o.obs.range ());
  Pose2 centre;
  centre.x = cx;
  centre.y = cy;
  const double v = 4 * reach * reach;
  const double cov[9] = { v, 0, 0, 0, v, 0, 0, 0, M_PI * M_PI };
  init_pose (centre, cov);
  Pose2 at;
  std::vector<int> assign;
  bool weak;
  if (relocalise (obs, &at, &assign, &weak) && reloc_confirmed (assign, weak))
    return true;
  init_ = false;
  s_.clear ();
  p_.clear ();
  return false;
}

/* Relocalisation of a lost pose. Pairings are hypothesised from what does
 * not depend on the pose: the distance between two detections against the
 * distance between two landmarks of their classes, the widest detection
 * pairs first (the best heading). Each hypothesis places the robot (the
 * rigid motion taking the two detections onto the two landmarks) and is
 * scored by the detections it then explains; the most, then the nearest
 * to the predicted pose, wins, if the prediction allows it and no other
 * that places the robot elsewhere explains as many. Explained
 * detections beyond the two seeds must be unlikely by chance: each
 * detection's chance of some landmark of its class within its tolerance,
 * from the class's density over the mapped area, summed to a Poisson mean;
 * its tail times the hypotheses (those not tried counted) must stay under
 * opt.reloc_chance. The work (landmark comparisons) is bounded per frame;
 * a search cut short accepts only on that chance test. */
bool
Slam::relocalise (const std::vector<SlamObservation> & obs, Pose2 * at,
    std::vector<int> *assign, bool *weak) const
{
  *weak = false;
  const size_t N = n (), no = obs.size (), nl = lm_.size ();
  if (nl < 2)
    return false;
  std::vector<double> var (no);    /* detection's position variance */
  for (size_t i = 0; i < no; i++) {
    double sr, sb;
    slam_observation_sigmas (obs[i], 1, &sr, &sb);
    var[i] = sr * sr + std::pow (obs[i].obs.range () * sb, 2);
  }
  std::vector<double> lm_var (nl);
  double x0 = lm_[0].x, x1 = x0, y0 = lm_[0].y, y1 = y0;
  for (size_t k = 0; k < nl; k++) {
    lm_var[k] = std::pow (max_sigma_2x2 (lm_[k].cov), 2);
    x0 = std::min (x0, lm_[k].x);
    x1 = std::max (x1, lm_[k].x);
    y0 = std::min (y0, lm_[k].y);
    y1 = std::max (y1, lm_[k].y);
  }
  /* per detection, the landmarks of its class and their mean variance */
  std::vector<std::vector<int>> same (no);
  std::vector<double> same_var (no, 0);
  for (size_t i = 0; i < no; i++) {
    for (size_t k = 0; k < nl; k++)
      if (lm_[k].class_name == obs[i].class_name) {
        same[i].push_back ((int) k);
        same_var[i] += lm_var[k];
      }
    if (!same[i].empty ())
      same_var[i] /= same[i].size ();
  }
  double lm_var_max = 0;
  for (double v : lm_var)
    lm_var_max = std::max (lm_var_max, v);
  /* the landmarks on a grid, so that a detection is scored against those
   * near where a hypothesis puts it, not against all of its class */
  const double cell = 0.5;
  std::unordered_map<long long, std::vector<int>> grid;
  auto cell_key = [&](long long cx, long long cy) {
    return cx * 2000003LL + cy;
  };
  for (size_t k = 0; k < nl; k++)
    grid[cell_key ((long long) std::floor ((lm_[k].x - x0) / cell),
            (long long) std::floor ((lm_[k].y - y0) / cell))].push_back ((int) k);
  cv::Matx33d Pxx;
  for (int i = 0; i < 3; i++)
    for (int j = 0; j < 3; j++)
      Pxx (i, j) = p_[i * N + j];
  const cv::Matx33d Pinv = Pxx.inv (cv::DECOMP_SVD);
  const double plausible = chi2_quantile (opt.joint_probability, 3);
  const double pc[4] = { Pxx (0, 0), Pxx (0, 1), Pxx (1, 0), Pxx (1, 1) };
  const double pos_sigma = max_sigma_2x2 (pc);
  /* seed pairs, widest first */
  struct Seed {
    int i, j;
    double dz;
  };
  std::vector<Seed> seeds;
  for (size_t i = 0; i < no; i++)
    for (size_t j = i + 1; j < no; j++) {
      const double dz = std::hypot (obs[j].obs.gx - obs[i].obs.gx,
          obs[j].obs.gy - obs[i].obs.gy);
      if (dz >= opt.min_separation && !same[i].empty () && !same[j].empty ())
        seeds.push_back ({ (int) i, (int) j, dz });
    }
  std::stable_sort (seeds.begin (), seeds.end (),
      [](const Seed & a, const Seed & b) { return a.dz > b.dz; });
  struct Hyp {
    std::vector<int> assign;
    Pose2 pose;
    int inliers = 0;
    double d2 = 0;
    double lambda = 0;  /* chance inliers beyond the seeds, expected */
    int seeds[2] = { -1, -1 };
    bool weak = false;  /* two, the prediction no help: the map's word */
  };
  /* the best hypothesis, and the others that explain as many detections
   * with other pairings (rivals: the pose they place and its seeds'
   * lever); buffers reused */
  Hyp best, h;
  struct Rival {
    Pose2 pose;
    double seed_var, lever;
  };
  std::vector<Rival> rivals;
  double best_seed_var = 0, best_lever = 0;
  std::vector<bool> taken (nl);
  std::vector<int> cand_i, cand_j, near;
  /* work: landmark pairs compared and landmarks scored; hypotheses: those
   * the prediction allows, each scored */
  const long budget = opt.reloc_max_comparisons;
  long work = 0, compared = 0, hypotheses = 0;
  double untried = 0;   /* landmark pairs not compared */
  /* the detections a hypothesis explains, each with its nearest free
   * landmark of its class within a tolerance that adds `pose_var` (the
   * variance the hypothesis' own error adds at that detection), and the
   * inliers chance alone would give it */
  auto score = [&](Hyp * h, const std::function<double (size_t)> & pose_var) {
    const double c = std::cos (h->pose.heading),
        sn = std::sin (h->pose.heading);
    h->inliers = 0;
    h->lambda = 0;
    h->assign.assign (no, -1);
    taken.assign (nl, false);
    for (size_t m = 0; m < no; m++) {
      double nearest_e2 = std::numeric_limits<double>::infinity ();
      const double extra = pose_var (m);
      /* where the hypothesis puts the detection, and the cells its
       * widest tolerance reaches */
      const double px = h->pose.x + c * obs[m].obs.gx - sn * obs[m].obs.gy,
          py = h->pose.y + sn * obs[m].obs.gx + c * obs[m].obs.gy;
      const double reach = std::sqrt (opt.gate_chi2 * (var[m] + lm_var_max
              + extra));
      near.clear ();
      /* only the cells that hold landmarks: a wide tolerance (a detection
       * far beyond two close seeds) must not walk empty space */
      auto cell_range = [&](double p, double lo, double hi, long long *a,
          long long *b) {
        const double last = std::floor ((hi - lo) / cell);
        *a = (long long) std::clamp (std::floor ((p - reach - lo) / cell),
            0.0, last);
        *b = (long long) std::clamp (std::floor ((p + reach - lo) / cell),
            0.0, last);
        return std::isfinite (p) && std::isfinite (reach)
            && p + reach >= lo && p - reach <= hi + cell;
      };
      long long cx0, cx1, cy0, cy1;
      if (!cell_range (px, x0, x1, &cx0, &cx1)
          || !cell_range (py, y0, y1, &cy0, &cy1))
        cx1 = cx0 - 1;          /* nothing within reach */
      for (long long cx = cx0; cx <= cx1; cx++)
        for (long long cy = cy0; cy <= cy1; cy++) {
          work++;
          const auto it = grid.find (cell_key (cx, cy));
          if (it != grid.end ())
            near.insert (near.end (), it->second.begin (), it->second.end ());
        }
      /* in index order, as a scan of the class would meet them */
      std::sort (near.begin (), near.end ());
      for (int q : near) {
        work++;
        if (lm_[q].class_name != obs[m].class_name || taken[q])
          continue;
        const double wx = lm_[q].x - h->pose.x, wy = lm_[q].y - h->pose.y;
        const double ex = c * wx + sn * wy - obs[m].obs.gx,
            ey = -sn * wx + c * wy - obs[m].obs.gy;
        const double e2 = ex * ex + ey * ey;
        const double tol = opt.gate_chi2 * (var[m] + lm_var[q] + extra);
        if (e2 < tol && e2 < nearest_e2) {
          nearest_e2 = e2;
          h->assign[m] = q;
        }
      }
      if (h->assign[m] >= 0) {
        taken[h->assign[m]] = true;
        h->inliers++;
      }
      /* by chance: some landmark of its class within its tolerance disk,
       * the class spread over the mapped area grown by it */
      if ((int) m != h->seeds[0] && (int) m != h->seeds[1]
          && !same[m].empty ()) {
        const double tol = opt.gate_chi2 * (var[m] + same_var[m] + extra);
        const double grow = 2 * std::sqrt (tol);
        const double area = (x1 - x0 + grow) * (y1 - y0 + grow);
        h->lambda += 1 - std::exp (-(double) same[m].size () * M_PI * tol
            / area);
      }
    }
  };
  size_t s = 0;
  for (; s < seeds.size () && work < budget; s++) {
    const int i = seeds[s].i, j = seeds[s].j;
    const double dz = seeds[s].dz;
    const auto & zi = obs[i].obs, &zj = obs[j].obs;
    const double lever = 1 / (dz * dz);
    /* a seed's landmark at the detection's range from the predicted
     * position, within what the prediction allows (whatever the heading)
     * and half the distance mismatch the pair may have */
    const double slack = std::sqrt (plausible) * pos_sigma
        + std::sqrt (opt.gate_chi2 * (var[i] + var[j] + 2 * lm_var_max));
    auto near_range = [&](int d, std::vector<int> *out) {
      out->clear ();
      const double r = obs[d].obs.range ();
      for (int k : same[d]) {
        work++;
        const double e = std::hypot (lm_[k].x - s_[0], lm_[k].y - s_[1]) - r;
        if (e * e <= std::pow (slack + std::sqrt (lm_var[k] + var[d]), 2))
          out->push_back (k);
      }
    };
    near_range (i, &cand_i);
    near_range (j, &cand_j);
    /* pairs (cand_i[a], cand_j[b]) in order; the budget is checked
     * before each */
    size_t a = 0, b = 0;
    for (; a < cand_i.size () && work < budget; a++) {
      const int k = cand_i[a];
      for (b = 0; b < cand_j.size () && work < budget; b++) {
        const int l = cand_j[b];
        work++;
        compared++;
        if (k == l)
          continue;
        const double dl = std::hypot (lm_[l].x - lm_[k].x,
            lm_[l].y - lm_[k].y);
        const double v = var[i] + var[j] + lm_var[k] + lm_var[l];
        if ((dz - dl) * (dz - dl) > opt.gate_chi2 * v)
          continue;
        h.pose.heading = wrap_angle (std::atan2 (lm_[l].y - lm_[k].y,
                lm_[l].x - lm_[k].x) - std::atan2 (zj.gy - zi.gy,
                zj.gx - zi.gx));
        const double c = std::cos (h.pose.heading),
            sn = std::sin (h.pose.heading);
        h.pose.x = 0.5 * (lm_[k].x + lm_[l].x - c * (zi.gx + zj.gx)
            + sn * (zi.gy + zj.gy));
        h.pose.y = 0.5 * (lm_[k].y + lm_[l].y - sn * (zi.gx + zj.gx)
            - c * (zi.gy + zj.gy));
        const cv::Vec3d e (h.pose.x - s_[0], h.pose.y - s_[1],
            wrap_angle (h.pose.heading - s_[2]));
        h.d2 = e.dot (Pinv * e);
        /* one the prediction rules out can not be accepted: neither
         * scored nor counted */
        if (!(h.d2 < plausible))
          continue;
        hypotheses++;
        /* the two's heading error grows with the range over their
         * separation */
        h.seeds[0] = i;
        h.seeds[1] = j;
        score (&h, [&](size_t m) {
              return (1 + std::pow (obs[m].obs.range (), 2) * lever)
                  * (var[i] + var[j]);
            });
        /* two detections give one distance to check, weak evidence
         * among repeated colours (a spurious or unmapped one matches
         * some pair by chance): only while the predicted position is
         * known to within their separation, or on a given map, whose
         * markers are all there is to see (then only with no rival
         * anywhere, in consecutive frames: reloc_confirmed) */
        h.weak = h.inliers == 2 && pos_sigma > dz;
        if (!(h.inliers >= 3 || (h.inliers == 2 && (!h.weak || anchored_))))
          continue;
        /* as many: the nearer the prediction wins; another pairing
         * is a rival */
        const Rival mine { h.pose, var[i] + var[j], lever };
        const bool other = h.assign != best.assign;
        if (h.inliers > best.inliers)
          rivals.clear ();
        if (h.inliers > best.inliers || (h.inliers == best.inliers
                && h.d2 < best.d2)) {
          if (h.inliers == best.inliers && other)
            rivals.push_back ({ best.pose, best_seed_var, best_lever });
          best = h;
          best_seed_var = mine.seed_var;
          best_lever = mine.lever;
        } else if (h.inliers == best.inliers && other) {
          rivals.push_back (mine);
        }
      }
    }
    /* the seed pair's landmark pairs left when the budget ran out (the
     * row cut short, and the rows after it) */
    if (a > 0 && b < cand_j.size ())
      untried += (double) (cand_j.size () - b);
    untried += (double) (cand_i.size () - a) * cand_j.size ();
  }
  for (; s < seeds.size (); s++)
    untried += (double) same[seeds[s].i].size () * same[seeds[s].j].size ();
  const bool complete = untried == 0;
  /* a rival refuses the winner when it places the robot elsewhere: some
   * detection lands beyond the two poses' joint tolerance (each pose's
   * error at that detection, from its seeds' lever); one within is the
   * same place paired a little differently (near-duplicate pairings of
   * one pose), no evidence against it */
  auto elsewhere = [&](const Rival & r) {
    const double cb = std::cos (best.pose.heading),
        sb = std::sin (best.pose.heading), cr = std::cos (r.pose.heading),
        sr = std::sin (r.pose.heading);
    for (size_t m = 0; m < no; m++) {
      const double gx = obs[m].obs.gx, gy = obs[m].obs.gy,
          r2 = obs[m].obs.range () * obs[m].obs.range ();
      const double dx = best.pose.x + cb * gx - sb * gy
          - (r.pose.x + cr * gx - sr * gy),
          dy = best.pose.y + sb * gx + cb * gy
          - (r.pose.y + sr * gx + cr * gy);
      const double tol = opt.gate_chi2 * ((1 + r2 * best_lever)
          * best_seed_var + (1 + r2 * r.lever) * r.seed_var);
      if (dx * dx + dy * dy > tol)
        return true;
    }
    return false;
  };
  const bool ambiguous = std::any_of (rivals.begin (), rivals.end (),
      elsewhere);
  /* the hypotheses not tried, at the rate the compared pairs gave them */
  const double all_hypotheses = hypotheses + untried * (hypotheses + 1)
      / std::max<long> (compared, 1);
  /* the best refitted on all it explains (a rigid fit), scored again
   * with the fit's error in place of the seeds' lever: the tolerance
   * chance is judged at, and the pose accepted */
  if (best.inliers >= 3) {
    double zx = 0, zy = 0, lx = 0, ly = 0, v = 0;
    for (size_t m = 0; m < no; m++)
      if (best.assign[m] >= 0) {
        zx += obs[m].obs.gx;
        zy += obs[m].obs.gy;
        lx += lm_[best.assign[m]].x;
        ly += lm_[best.assign[m]].y;
        v += var[m] + lm_var[best.assign[m]];
      }
    const double nin = best.inliers;
    zx /= nin;
    zy /= nin;
    lx /= nin;
    ly /= nin;
    v /= nin;
    double sc = 0, ss = 0, spread = 0;
    for (size_t m = 0; m < no; m++)
      if (best.assign[m] >= 0) {
        const double ax = obs[m].obs.gx - zx, ay = obs[m].obs.gy - zy,
            bx = lm_[best.assign[m]].x - lx, by = lm_[best.assign[m]].y - ly;
        sc += ax * bx + ay * by;
        ss += ax * by - ay * bx;
        spread += ax * ax + ay * ay;
      }
    Hyp fit = best;
    fit.pose.heading = std::atan2 (ss, sc);
    const double c = std::cos (fit.pose.heading),
        sn = std::sin (fit.pose.heading);
    fit.pose.x = lx - (c * zx - sn * zy);
    fit.pose.y = ly - (sn * zx + c * zy);
    score (&fit, [&](size_t m) {
          return v / nin + v / std::max (spread, 1e-9)
              * (std::pow (obs[m].obs.gx - zx, 2)
                  + std::pow (obs[m].obs.gy - zy, 2));
        });
    /* the refitted pose answers to the prediction as the seeds' did */
    const cv::Vec3d e (fit.pose.x - s_[0], fit.pose.y - s_[1],
        wrap_angle (fit.pose.heading - s_[2]));
    fit.d2 = e.dot (Pinv * e);
    if (fit.inliers < 3 || !(fit.d2 < plausible))
      return false;
    best = fit;
  }
  const double chance = poisson_tail (best.lambda, best.inliers - 2)
      * all_hypotheses;
  if (best.inliers < 2 || ambiguous)
    return false;
  /* two: the prediction's word, taken only when every rival was tried;
   * more: those beyond the seeds unlikely by chance */
  if (best.inliers == 2 ? !complete : chance >= opt.reloc_chance)
    return false;
  *at = best.pose;
  *assign = best.assign;
  *weak = best.weak;
  return true;
}

}  // namespace landmark
