/* trilaterate frame by frame: see posetracker.h and docs/trilaterate.md. */
#include "posetracker.h"

#include <algorithm>
#include <cmath>

namespace landmark {

void
PoseTracker::reset ()
{
  have_last_ = false;
  reset_filter ();
}

void
PoseTracker::reset_filter ()
{
  ekf.reset ();
  have_ekf_time_ = false;
}

bool
PoseTracker::fresh (double since, double now, double max_age) const
{
  return now >= since && now - since <= max_age;
}

TrackedFrame
PoseTracker::step (const std::vector<MapPoint> & map,
    const std::vector<Detection> & dets, double now,
    const PoseTrackerOptions & o)
{
  /* the prior: predicted (ekf) or previous (none) pose */
  LocaliseOptions opt;
  opt.gate = o.gate;
  opt.lsq.inlier_gate = o.inlier_distance;
  double predicted_heading_sigma = 0;
  if (o.ekf && ekf.initialised ()) {
    if (have_ekf_time_ && fresh (ekf_measured_, now, o.max_age)) {
      if (now > ekf_time_)
        ekf.predict (now - ekf_time_);
      ekf_time_ = now;
      opt.have_prior = true;
      opt.prior = ekf.pose ();
      double c[9];
      ekf.pose_cov (c);
      predicted_heading_sigma = std::sqrt (std::max (0.0, c[8]));
    } else {
      reset_filter ();
    }
  } else if (!o.ekf && have_last_ && fresh (last_time_, now, o.max_age)) {
    /* the previous pose places the detections of repeated colours for the
     * gate; its heading is no measurement of this frame's */
    opt.have_prior = true;
    opt.prior = last_;
  }
  if (o.have_heading) {
    opt.have_heading = true;
    opt.heading = wrap_angle (o.heading);
    opt.heading_sigma = o.heading_sigma;
  } else if (o.ekf && opt.have_prior) {
    /* the filter's prediction: a heading measured by the motion model,
     * with the uncertainty it has grown since the last update */
    opt.have_heading = true;
    opt.heading = opt.prior.heading;
    opt.heading_sigma = predicted_heading_sigma;
  }

  TrackedFrame out;
  out.res = localise (map, dets, opt);
  const LocaliseResult & res = out.res;
  if (!o.ekf && !res.ok) {
    /* no pose, and the previous pose's heading may be stale by now: a
     * repeated colour it places outside the gate is unnamed, not
     * rejected (the filter's prediction, with its own uncertainty, does
     * reject) */
    for (auto & r : out.res.reasons)
      if (r == "outside-gate")
        r = "too-few-landmarks";
  }
  PoseFields & fp = out.pose;
  fp.filter = o.ekf ? "ekf" : "none";
  std::vector<Correspondence> used;
  for (size_t k = 0; k < dets.size (); k++) {
    if (res.match[k] >= 0 && res.matched_by[k] == MatchedBy::Pose) {
      const auto & m = map[res.match[k]];
      used.push_back ({ dets[k].obs, m.x, m.y });
      fp.ids.push_back (m.id);
    }
  }
  if (res.ok) {
    out.ok = true;
    fp.pose = res.solution.pose;
    std::copy (res.solution.cov, res.solution.cov + 9, fp.cov);
    fp.residual = res.solution.residual;
    fp.solver = res.solution.solver;
    fp.geometry = geometry_name (res.solution.geometry);
  }
  if (o.ekf) {
    if (!ekf.initialised ()) {
      if (res.ok) {
        ekf.init (res.solution.pose, res.solution.cov);
        have_ekf_time_ = true;
        ekf_time_ = ekf_measured_ = now;
      }
    } else {
      if (res.ok && used.size () >= 3 && ekf.lost (res.solution, used)) {
        /* three or more landmarks place the robot by themselves; a filter
         * whose prediction they reject, half of them or more in a trial
         * update, has drifted beyond its own covariance (a turn bridged on
         * one landmark): updated, it would be pulled by the few that pass;
         * it restarts from their pose */
        ekf.init (res.solution.pose, res.solution.cov);
        ekf_measured_ = now;
      } else if (!res.ok) {
        /* no pose from the landmarks together (one of them far off its
         * pairing): the filter tests each pairing against its prediction
         * (used is empty without a solution; cleared again below) */
        for (size_t k = 0; k < res.paired.size (); k++)
          if (res.paired[k] >= 0)
            used.push_back ({ dets[k].obs, map[res.paired[k]].x,
                    map[res.paired[k]].y });
        if (!used.empty () && ekf.update (used) > 0)
          ekf_measured_ = now;
      } else if (!used.empty () && ekf.update (used) > 0) {
        ekf_measured_ = now;
      }
      out.ok = true;
      fp.pose = ekf.pose ();
      ekf.pose_cov (fp.cov);
      if (!res.ok) {
        fp.solver = "ekf";
        fp.ids.clear ();
        fp.geometry = "ok";
        used.clear ();
      }
      double sum = 0;
      for (const auto & c : used) {
        const double r = correspondence_residual (fp.pose, c);
        sum += r * r;
      }
      fp.residual = used.empty ()? 0 : std::sqrt (sum / used.size ());
    }
  }
  if (!out.ok)
    out.why = res.why.empty ()? "too-few-landmarks" : res.why;
  if (out.ok && !o.ekf) {
    have_last_ = true;
    last_ = fp.pose;
    last_time_ = now;
  }
  return out;
}

}  // namespace landmark
