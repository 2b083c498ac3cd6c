/* The landmark SLAM filter's landmarks (slam.h): adding one to the state
 * and removing it, their positions and covariances as reported, their
 * views, confirmation and the heading's uncertainty relative to them, and
 * a frame's new landmarks and dropped ones. */
#include "slam.h"
#include "slaminternal.h"

#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

namespace landmark {

namespace {

/* frames out of sight that end a pass over a landmark (half a second at
 * 30 fps): slam_observation_sigmas counts the views of one pass */
constexpr int kPassGap = 15;

}  // namespace

void
Slam::add_landmark (const SlamObservation & o, SlamLandmark lm)
{
  /* the detection's slow error first: the landmark starts from it */
  const bool slow = slow_errors ();
  const int bs = slow ? (int) n () : -1;
  if (slow)
    grow_states (2, opt.meas_slow_share, opt.meas_slow_share);
  const int N = (int) n ();
  const double r = o.obs.range (), b = o.obs.bearing ();
  double sr, sb;
  slam_observation_sigmas (o, 1, &sr, &sb);
  const double a = s_[2] + b, ca = std::cos (a), sa = std::sin (a);
  lm.x = s_[0] + r * ca;
  lm.y = s_[1] + r * sa;
  /* Jacobians of the landmark position w.r.t. the pose and (r, b): J
   * over the state (the pose's columns, and the slow error's, in sigmas),
   * Gz for the white error */
  const double Gz[4] = { ca, -r * sa, sa, r * ca };
  cv::Mat J = cv::Mat::zeros (2, N, CV_64F);
  J.at<double> (0, 0) = J.at<double> (1, 1) = 1;
  J.at<double> (0, 2) = -r * sa;
  J.at<double> (1, 2) = r * ca;
  if (slow)
    for (int i = 0; i < 2; i++) {
      J.at<double> (i, bs) = Gz[2 * i] * sr;
      J.at<double> (i, bs + 1) = Gz[2 * i + 1] * sb;
    }
  const double white = slow ? 1 - opt.meas_slow_share : 1;
  const double rr = white * sr * sr, rb = white * sb * sb;
  /* M (N x N) grown by the landmark's rows and columns: its correlation
   * with the rest through the pose and the slow error, J M, its own
   * block J M J^T, plus the white error's Gz R Gz^T where M holds it: P,
   * and the measurements' derivative of P (the slip's reaches the
   * landmark through the pose only) */
  auto grow = [&](std::vector<double> & m, bool with_measurement) {
    cv::Mat M (N, N, CV_64F, m.data ());
    cv::Mat Mlx = jacobian_times (J, M);        /* 2 x N */
    cv::Mat Mll = Mlx * J.t ();
    if (with_measurement) {
      Mll.at<double> (0, 0) += Gz[0] * Gz[0] * rr + Gz[1] * Gz[1] * rb;
      Mll.at<double> (0, 1) += Gz[0] * Gz[2] * rr + Gz[1] * Gz[3] * rb;
      Mll.at<double> (1, 0) += Gz[0] * Gz[2] * rr + Gz[1] * Gz[3] * rb;
      Mll.at<double> (1, 1) += Gz[2] * Gz[2] * rr + Gz[3] * Gz[3] * rb;
    }
    cv::Mat Mn = cv::Mat::zeros (N + 2, N + 2, CV_64F);
    M.copyTo (Mn (cv::Rect (0, 0, N, N)));
    Mlx.copyTo (Mn (cv::Rect (0, N, N, 2)));
    cv::Mat Mxl = Mlx.t ();
    Mxl.copyTo (Mn (cv::Rect (N, 0, 2, N)));
    Mll.copyTo (Mn (cv::Rect (N, N, 2, 2)));
    m.assign ((double *) Mn.data, (double *) Mn.data + (N + 2) * (N + 2));
  };
  const bool tracked = slip_tracked ();
  grow (p_, true);
  if (tracked) {
    grow (dp_[0], false);
    grow (dp_[1], true);
  }
  s_.push_back (lm.x);
  s_.push_back (lm.y);
  lm.views = 1;
  lm.confirmed = false;       /* decided with the others after the update */
  if (lm.id.empty ()) {
    /* ids not taken by the given map */
    for (;;) {
      std::string id = "S" + std::to_string (next_id_++);
      bool taken = false;
      for (const auto & l : lm_)
        taken |= l.id == id;
      if (!taken) {
        lm.id = id;
        break;
      }
    }
  }
  lm_.push_back (lm);
  slot_.push_back (N);
  last_view_.push_back (pose ());
  unseen_.push_back (0);
  pass_views_.push_back (1);   /* seen once, as views */
  bias_slot_.push_back (bs);
  bias_left_.push_back (1);
}

/* count states appended, uncorrelated with the rest: variance p_var in P,
 * 0 in the slip's derivative, meas_var in the measurements' */
void
Slam::grow_states (int count, double p_var, double meas_var)
{
  const int N = (int) n (), N2 = N + count;
  const bool tracked = slip_tracked ();
  auto grow = [&](std::vector<double> & m, double var) {
    std::vector<double> g ((size_t) N2 * N2, 0);
    for (int i = 0; i < N; i++)
      std::copy (m.begin () + (size_t) i * N, m.begin () + (size_t) (i + 1)
          * N, g.begin () + (size_t) i * N2);
    for (int i = N; i < N2; i++)
      g[(size_t) i * N2 + i] = var;
    m.swap (g);
  };
  grow (p_, p_var);
  if (tracked) {
    grow (dp_[0], 0);
    grow (dp_[1], meas_var);
  }
  s_.resize (N2, 0);
}

/* states first..first + count - 1 removed (marginalised), the landmarks'
 * and the slow errors' indices after them moved down */
void
Slam::remove_states (int first, int count)
{
  const int N = (int) n ();
  const bool tracked = slip_tracked ();
  std::vector<int> keep;
  for (int i = 0; i < N; i++)
    if (i < first || i >= first + count)
      keep.push_back (i);
  auto shrink = [&](std::vector<double> & m) {
    std::vector<double> out;
    out.reserve (keep.size () * keep.size ());
    for (int i : keep)
      for (int j : keep)
        out.push_back (m[(size_t) i * N + j]);
    m.swap (out);
  };
  shrink (p_);
  if (tracked) {
    shrink (dp_[0]);
    shrink (dp_[1]);
  }
  std::vector<double> s2;
  for (int i : keep)
    s2.push_back (s_[i]);
  s_.swap (s2);
  for (auto *slots : { &slot_, &bias_slot_ })
    for (auto & o : *slots)
      if (o > first)
        o -= count;
}

/* landmark k's slow error as states, from its prior (uncorrelated: as if
 * folded into the measurement's variance, what the gates assumed) */
void
Slam::add_bias (size_t k)
{
  if (bias_slot_[k] >= 0)
    return;
  bias_slot_[k] = (int) n ();
  bias_left_[k] = 1;
  grow_states (2, opt.meas_slow_share, opt.meas_slow_share);
}

/* The slow errors over `distance` driven (and turned): b <- rho b plus
 * white noise
 * keeping their variance at the share, rho = exp(-distance / length);
 * the slip's derivative decays only, the measurements' as P */
void
Slam::decay_biases (double distance)
{
  if (!(distance > 0))
    return;
  const int N = (int) n ();
  const double rho = std::exp (-distance / std::max (opt.meas_slow_length,
          1e-9)), q = (1 - rho * rho) * opt.meas_slow_share;
  const bool tracked = slip_tracked ();
  for (size_t k = 0; k < bias_slot_.size (); k++) {
    const int bs = bias_slot_[k];
    if (bs < 0)
      continue;
    bias_left_[k] *= rho;
    for (int c = 0; c < 3; c++) {
      if (c > 0 && !tracked)
        break;
      double *M = c == 0 ? p_.data () : dp_[c - 1].data ();
      for (int b = bs; b < bs + 2; b++) {
        for (int j = 0; j < N; j++) {
          M[(size_t) b * N + j] *= rho;
          M[(size_t) j * N + b] *= rho;
        }
        if (c != 1)
          M[(size_t) b * N + b] += q;
      }
    }
    s_[bs] *= rho;
    s_[bs + 1] *= rho;
  }
}

void
Slam::set_slow_errors (double share, double length)
{
  if (share == opt.meas_slow_share && length == opt.meas_slow_length)
    return;
  for (size_t k = 0; k < bias_slot_.size (); k++)
    if (bias_slot_[k] >= 0) {
      remove_states (bias_slot_[k], 2);
      bias_slot_[k] = -1;
    }
  opt.meas_slow_share = share;
  opt.meas_slow_length = length;
}

/* a slow error of a landmark out of view that has decayed to e^-3 of
 * what it was when last seen is independent of what follows:
 * marginalised (its rows and columns dropped), so the state holds the
 * slow errors of the landmarks in view, or lately */
void
Slam::drop_biases ()
{
  for (size_t k = 0; k < bias_slot_.size (); k++)
    if (bias_slot_[k] >= 0 && unseen_[k] > 0 && bias_left_[k] < 0.05) {
      remove_states (bias_slot_[k], 2);
      bias_slot_[k] = -1;
    }
}

void
Slam::remove_landmark (size_t k)
{
  if (bias_slot_[k] >= 0)
    remove_states (bias_slot_[k], 2);
  if (slot_[k] >= 0)
    remove_states (slot_[k], 2);
  lm_.erase (lm_.begin () + k);
  bias_slot_.erase (bias_slot_.begin () + k);
  bias_left_.erase (bias_left_.begin () + k);
  slot_.erase (slot_.begin () + k);
  last_view_.erase (last_view_.begin () + k);
  unseen_.erase (unseen_.begin () + k);
  pass_views_.erase (pass_views_.begin () + k);
}

void
Slam::sync_landmarks ()
{
  const size_t N = n ();
  for (size_t k = 0; k < lm_.size (); k++) {
    const int sl = slot_[k];
    if (sl < 0)
      continue;
    lm_[k].x = s_[sl];
    lm_[k].y = s_[sl + 1];
    double f[9];
    frame_cov_at (s_[sl], s_[sl + 1], f);
    lm_[k].cov[0] = p_[sl * N + sl] + f[0];
    lm_[k].cov[1] = p_[sl * N + sl + 1] + f[1];
    lm_[k].cov[2] = p_[(sl + 1) * N + sl] + f[3];
    lm_[k].cov[3] = p_[(sl + 1) * N + sl + 1] + f[4];
  }
}

void
Slam::confirm_known ()
{
  /* known = relative to the robot: the landmark's covariance given the
   * pose, P_ll - P_lx P_xx^-1 P_xl. Its marginal in the map frame also
   * holds the drift the robot had gathered when it first saw it, which
   * the landmark shares with its neighbours and which no observation of
   * it can remove until a loop closes. */
  const int N = (int) n ();
  if (!init_)
    return;
  cv::Mat P (N, N, CV_64F, p_.data ());
  cv::Mat Pxx_inv;
  cv::invert (P (cv::Rect (0, 0, 3, 3)), Pxx_inv, cv::DECOMP_SVD);
  for (size_t k = 0; k < lm_.size (); k++) {
    SlamLandmark & l = lm_[k];
    const int sl = slot_[k];
    if (l.anchor || l.confirmed || sl < 0 || l.views < opt.confirm_views)
      continue;
    cv::Mat Plx = P (cv::Rect (0, sl, 3, 2));
    cv::Mat C = P (cv::Rect (sl, sl, 2, 2)) - Plx * Pxx_inv * Plx.t ();
    const double c[4] = { C.at<double> (0, 0), C.at<double> (0, 1),
      C.at<double> (1, 0), C.at<double> (1, 1) };
    if (max_sigma_2x2 (c) <= opt.confirm_sigma)
      l.confirmed = true;
  }
}

double
Slam::heading_var_to_map () const
{
  const int N = (int) n ();
  /* anchors are exact: the marginal is already relative to them */
  if (anchored_)
    return p_[2 * N + 2];
  /* the map's orientation: the least-squares turn of its landmarks about
   * their centroid, phi = sum_i (-d_iy dx_i + d_ix dy_i) / sum_i |d_i|^2
   * for displacements (dx_i, dy_i), d_i = l_i - centroid (the centroid's
   * own shift is a translation: sum_i J d_i = 0 takes it out) */
  std::vector<int> slots;
  double cx = 0, cy = 0;
  for (int sl : slot_)
    if (sl >= 0) {
      slots.push_back (sl);
      cx += s_[sl];
      cy += s_[sl + 1];
    }
  /* fewer than two: no orientation for a heading to be wrong against */
  if (slots.size () < 2)
    return 0;
  cx /= slots.size ();
  cy /= slots.size ();
  double D = 0;
  for (int sl : slots)
    D += std::pow (s_[sl] - cx, 2) + std::pow (s_[sl + 1] - cy, 2);
  if (!(D > 1e-12))
    return p_[2 * N + 2];
  /* a' P a over the non-zero entries of a = d(heading - phi) / d(state) */
  std::vector<std::pair<int, double>> a { { 2, 1.0 } };
  for (int sl : slots) {
    a.push_back ({ sl, (s_[sl + 1] - cy) / D });
    a.push_back ({ sl + 1, -(s_[sl] - cx) / D });
  }
  double v = 0;
  for (const auto & [i, ai] : a)
    for (const auto & [j, aj] : a)
      v += ai * aj * p_[i * N + j];
  return std::max (0.0, v);
}

void
Slam::joint_cov (size_t k, double cov[25]) const
{
  const int N = (int) n ();
  const int sl = k < slot_.size ()? slot_[k] : -1;
  const int idx[5] = { 0, 1, 2, sl, sl + 1 };
  for (int i = 0; i < 5; i++)
    for (int j = 0; j < 5; j++)
      cov[i * 5 + j] = init_ && (i < 3 || sl >= 0) && (j < 3 || sl >= 0)
          ? p_[idx[i] * N + idx[j]] : 0;
}

/* Views, confirmation, the unseen count. Confirmed = exists (paired in
 * confirm_views frames: a spurious blob rarely recurs inside the gate)
 * and is known (position sigma at most confirm_sigma). Range and bearing
 * fix a landmark from one pose, so no baseline is needed for its
 * geometry. A landmark once confirmed stays so. */
void
Slam::count_views (const SlamFrame & f)
{
  const Pose2 now = pose ();
  for (size_t k = 0; k < lm_.size (); k++) {
    bool seen = false;
    for (int mi : f.match)
      seen |= mi == (int) k;
    if (!seen) {
      unseen_[k]++;
      continue;
    }
    /* a pass ends when the landmark has been out of sight a while: the
     * blob is then cut another way (slam_observation_sigmas) */
    if (unseen_[k] > kPassGap)
      pass_views_[k] = 0;
    pass_views_[k]++;
    unseen_[k] = 0;
    bias_left_[k] = 1;
    if (std::hypot (now.x - last_view_[k].x, now.y - last_view_[k].y)
        >= opt.confirm_baseline) {
      lm_[k].views++;
      last_view_[k] = now;
    }
  }
}

/* RMS distance of the matched observations from their landmarks, with the
 * updated pose (0 when none matched). */
double
Slam::matched_residual (const std::vector<SlamObservation> & obs,
    const SlamFrame & f) const
{
  const Pose2 now = pose ();
  double sum = 0;
  for (size_t i = 0; i < obs.size (); i++) {
    if (f.match[i] < 0)
      continue;
    const auto & l = lm_[f.match[i]];
    double gx, gy;
    world_to_robot (now, l.x, l.y, &gx, &gy);
    sum += std::pow (gx - obs[i].obs.gx, 2) + std::pow (gy - obs[i].obs.gy, 2);
  }
  return f.n_matched ? std::sqrt (sum / f.n_matched) : 0;
}

/* New landmarks: unmatched and far from every landmark of the class
 * (the reason in f.reasons otherwise). */
void
Slam::start_landmarks (const std::vector<SlamObservation> & obs,
    SlamFrame & f)
{
  for (size_t i = 0; i < obs.size (); i++) {
    if (f.match[i] >= 0)
      continue;
    double wx, wy;
    robot_to_world (pose (), obs[i].obs.gx, obs[i].obs.gy, &wx, &wy);
    bool near = false;
    for (const auto & l : lm_)
      near |= l.class_name == obs[i].class_name
          && std::hypot (l.x - wx, l.y - wy) < opt.min_separation;
    if (near) {
      f.reasons[i] = "ambiguous";
      continue;
    }
    /* A landmark starts from the pose: its position is off by
     * r (1 - cos e) ~ r e^2 / 2 for a heading error e, which the
     * linearised covariance leaves out. What matters is the heading's
     * error relative to the map the landmark joins: with the heading's
     * sigma at tens of degrees relative to the mapped landmarks (after a
     * turn bridged on no landmark) that is decimetres at 2 m, the copy
     * would be confirmed where the pose was wrong and later pull the
     * pose there. Wait until that error is within the map accuracy asked
     * for (confirm_sigma). The heading's error relative to the start is
     * no reason: without anchors, a heading error shared by the pose and
     * the map is a turn of the free frame (a robot that drove 7 m before
     * its first landmark, 20 degrees off the start, still maps; its
     * covariance holds that turn to first order). Tested before the
     * gates below, which cost a pairing per landmark of the class (on a
     * lost frame among many, most of its time) */
    if (0.5 * obs[i].obs.range () * heading_var_to_map ()
        > opt.confirm_sigma) {
      f.reasons[i] = "uncertain-heading";
      continue;
    }
    double d2 = std::numeric_limits<double>::infinity ();
    {
      const int N2 = (int) n ();
      const cv::Mat P (N2, N2, CV_64F, p_.data ());
      for (size_t k = 0; k < lm_.size (); k++) {
        if (lm_[k].class_name != obs[i].class_name)
          continue;
        Pairing pr;
        if (make_pairing (obs, (int) i, (int) k, P, &pr))
          d2 = std::min (d2, pr.d2);
        else
          d2 = 0;
      }
    }
    if (d2 < opt.new_chi2) {
      f.reasons[i] = "ambiguous";
      continue;
    }
    if (lm_.size () >= opt.max_landmarks) {
      f.reasons[i] = "map-full";
      continue;
    }
    if (!anchored_ && std::none_of (slot_.begin (), slot_.end (),
            [](int sl) { return sl >= 0; }))
      rebase ();
    SlamLandmark l;
    l.class_name = obs[i].class_name;
    l.z = obs[i].marker_z;
    l.diameter = obs[i].marker_diameter;
    l.ball = obs[i].marker_ball;
    add_landmark (obs[i], l);
    f.match[i] = (int) lm_.size () - 1;
    f.reasons[i] = "new-landmark";
    f.n_new++;
    sync_landmarks ();
  }
}

/* Landmarks that never showed they exist, unseen too long: a spurious
 * detection. One that exists but is not known well enough stays, to be
 * confirmed when seen again (a loop closing shrinks it). */
void
Slam::drop_unseen (SlamFrame & f)
{
  for (size_t k = lm_.size (); k-- > 0;) {
    if (!lm_[k].confirmed && !lm_[k].anchor
        && lm_[k].views < opt.confirm_views
        && unseen_[k] > opt.tentative_frames) {
      for (auto & mi : f.match)
        if (mi > (int) k)
          mi--;
      remove_landmark (k);
    }
  }
}

}  // namespace landmark
