/* Landmark SLAM (docs/landmarkslam.md): an extended Kalman filter over the
 * robot's pose and velocity and the positions of the landmarks it has
 * seen, with range-bearing measurements.
 *
 * - Motion: constant velocity of a ground robot (it drives along its
 *   heading; the camera ahead of the turning centre), or robot-frame
 *   odometry increments whose
 *   scale error and heading drift are part of the state, and whose slip
 *   (white noise) is stated and, optionally, scaled by what the updates'
 *   innovations show of it (odo_slip_adapt).
 * - A landmark starts from one range and bearing, with the covariance that
 *   the pose's and the measurement's uncertainties give it. It is
 *   confirmed once it exists (paired in `confirm_views` frames, from poses
 *   `confirm_baseline` apart) and is known (the largest standard deviation
 *   of its position relative to the robot, its covariance given the pose,
 *   at most `confirm_sigma`); one that
 *   never reached `confirm_views` and is unseen for `tentative_frames`
 *   updates is dropped.
 * - Measurement noise: ipmrange's sigmas, widened by the disagreement of
 *   its floor and size ranges when it gives both (a blob segmented in part
 *   moves its centre by about as much as its size range moves), the more
 *   the more views the landmark has (that error repeats).
 * - Association: by class, each detection gated against each landmark by
 *   Mahalanobis distance, then joint compatibility branch and bound (JCBB):
 *   the largest one-to-one set of pairings whose joint innovation passes
 *   the chi-square test, so two landmarks of one colour are never fed the
 *   same detection and one detection never feeds two. A detection starts
 *   a new landmark only when it is far (`new_chi2`) from every landmark of
 *   its class; one between the gates is left out of the frame.
 * - A lost pose (heading sigma beyond pi / sqrt(gate): the gate's bearing
 *   span is the whole circle) pairs nothing alone; it is relocalised on two
 *   or more detections matched to landmarks by their mutual distances.
 * - Frame: landmarks of a given map are anchors (exact); without any, the
 *   first pose is the origin with heading 0.
 *
 * No GStreamer types: tested on its own (suite 'core'). Frames and units as
 * docs/conventions.md. The filter (prediction, update, slip) is in
 * slam.cpp, the association (gates, JCBB, relocalisation) in
 * slamassociation.cpp, the landmarks' bookkeeping in slamlandmarks.cpp. */
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "groundmotion.h"
#include "posesolver.h"

namespace landmark {

struct SlamOptions {
  /* without odometry, a ground robot's constant-velocity motion
   * (core/estimation/groundmotion.h, docs/landmarkslam.md "Motion"), the camera a
   * distance d ahead of the turning centre (a state, prior sigma
   * offset_sigma) */
  GroundMotionNoise motion;
  double offset_sigma = 0.1;      /* m */
  double gate_chi2 = 13.82;       /* per pairing, 2 dof (99.9 %) */
  double joint_probability = 0.999;   /* JCBB joint test */
  double new_chi2 = 40.0;         /* farther than this from all: new */
  /* and no nearer than this (metres) to a landmark of its class: ranges
   * biased beyond their sigmas (a disc cut by the image border) must not
   * add copies; two same-coloured markers closer than this are one */
  double min_separation = 0.2;
  /* existence: frames a landmark is paired in before it counts as real
   * (a spurious blob rarely recurs where the filter predicts it) */
  int confirm_views = 3;
  double confirm_baseline = 0;    /* metres between counted views */
  /* knowledge: largest position sigma (metres) given the pose, to confirm */
  double confirm_sigma = 0.03;
  int tentative_frames = 30;      /* updates a new one may go unseen */
  unsigned max_landmarks = 128;
  /* odometry: its scale error and heading drift are estimated (state),
   * these are their prior sigmas (a wheel radius 5 % off, wheels unequal
   * by about 3 degrees of turn per metre)... */
  double odo_scale_sigma = 0.05;
  double odo_drift_sigma = 0.05;  /* rad per m */
  /* ...and the white noise, slip only now that the systematic errors
   * are states: random walks over the distance driven and the angle
   * turned, a step's variance sigma^2 * length, whatever the odometry's
   * rate; good wheel odometry on a hard floor: 2 mm and 0.1 degree of
   * heading after a metre, 0.3 degrees after a turn in place
   * (docs/landmarkslam.md, "Odometry noise") */
  double odo_trans_sigma = 0.002; /* m per sqrt(m) */
  double odo_rot_sigma = 0.002;   /* rad per sqrt(rad) */
  double odo_rot_per_m = 0.002;   /* rad per sqrt(m) */
  /* the slip actually met, learnt while running: one scale of the three
   * sigmas above, from the landmarks' innovations after odometry
   * predictions (a variance-component estimate beside one of the
   * measurements' scale, which it must not absorb), bounded to
   * odo_slip_scale_min..max, its evidence forgotten over
   * odo_slip_window metres (plus as many radians turned); prior weight:
   * odo_slip_prior frames whose innovation the slip alone would make
   * (docs/landmarkslam.md, "Odometry slip, stated or learned") */
  bool odo_slip_adapt = true;
  /* by default only upward: the innovations that would draw the slip
   * below its statement are also shaped by landmarks mapped off beyond
   * their covariance, and a smaller slip left the pose over-confident
   * there (docs/landmarkslam.md, "Odometry slip, stated or learned") */
  double odo_slip_scale_min = 1.0, odo_slip_scale_max = 4.0;
  double odo_slip_window = 50.0;
  double odo_slip_prior = 1.0;
  /* the camera's floor point is this far ahead of the point whose motion
   * the odometry reports (a differential drive's turning centre, the
   * middle of its axle); 0: the odometry reports the camera's own motion
   * (docs/landmarkslam.md, "The odometry's frame") */
  double odo_camera_forward = 0;  /* m */
  /* The measurements' slow error: this share of each detection's stated
   * variance is an error that changes only slowly with the viewpoint
   * (a blob's outline cut the same way frame after frame,
   * docs/ranging.md item 7), the rest white. Each landmark in view
   * carries it as two states (range and bearing, in stated sigmas), a
   * first-order Gauss-Markov process over the distance driven plus the
   * angle turned (a radian as a metre: the landmark moves in the
   * image), correlation length meas_slow_length, marginalised once the
   * landmark is out of view for three lengths; 0: every error white
   * (docs/landmarkslam.md, "Slow measurement errors") */
  double meas_slow_share = 0.5;
  double meas_slow_length = 0.3;  /* m */
  int max_jcbb_nodes = 2000;      /* bounds the search per frame */
  /* relocalisation: landmark comparisons per frame (about 1 ms), and the
   * largest probability, over all the hypotheses of a frame, that chance
   * alone explains as many detections as the accepted one does
   * (docs/landmarkslam.md, "A lost pose") */
  long reloc_max_comparisons = 40000;
  double reloc_chance = 0.01;
  /* with a given map (anchors), two detections relocalise a lost pose
   * whose predicted position is no help (its sigma beyond their
   * separation), or place the first pose where the map's repeated
   * colours leave trilaterate's solvers none, when no other pairing with
   * the map explains them, in this many consecutive frames (a blob seen
   * once is not taken for a landmark) */
  int reloc_confirm_frames = 3;
};

/* A map landmark (id, class, position, and the marker: the given map's,
 * written back by map-out) with what the estimate knows of it. */
struct SlamLandmark : MapLandmark {
  double cov[4] = { 0 };          /* row-major, x y */
  int views = 0;                  /* frames paired in, confirm_baseline apart */
  bool confirmed = false;
  bool anchor = false;            /* from the given map: fixed */
};

struct SlamObservation {
  std::string class_name;
  RangeBearing obs;
  /* the marker the range assumed (ipmrange), kept by a new landmark */
  double marker_z = 0, marker_diameter = 0;
  bool marker_ball = false;
  /* ipmrange's size range minus its floor range, beyond what their pixel
   * noise explains (0 when within, or when it gave one range): evidence of
   * an error of the blob's centre that its sigmas omit */
  double range_disagreement = 0;
};

/* The range and bearing sigmas the filter uses for an observation that
 * would be its landmark's `repeat`-th view (1: a new landmark). */
void slam_observation_sigmas (const SlamObservation & o, int repeat,
    double *range_sigma, double *bearing_sigma);

/* Largest standard deviation of a 2x2 covariance (row-major). */
double max_sigma_2x2 (const double cov[4]);

struct SlamFrame {
  bool ok = false;                /* a pose exists */
  std::string why;                /* when !ok */
  std::vector<int> match;         /* per observation: landmark index, -1 */
  /* per observation: "new-landmark", "ambiguous", "uncertain-heading",
   * "no-pose", "map-full", empty when matched */
  std::vector<std::string> reasons;
  int n_matched = 0;
  int n_new = 0;
  double joint_nis = 0;           /* of the matched set */
  double residual = 0;            /* RMS position residual, m (after) */
};

/* Chi-square quantile for `dof` degrees of freedom (even or odd). */
double chi2_quantile (double p, int dof);

class Slam {
public:
  explicit Slam (const SlamOptions & o = SlamOptions ()) : opt (o) {}
  SlamOptions opt;

  /* Anchors: landmarks of a known map. Resets the state. */
  void set_map (const std::vector<MapPoint> & map);
  void reset ();

  bool has_pose () const { return init_; }
  Pose2 pose () const;
  void pose_cov (double cov[9]) const;
  const std::vector<SlamLandmark> & landmarks () const { return lm_; }
  /* The joint covariance of the pose (x, y, heading) and landmark k
   * (x, y), 5 x 5 row-major, as filtered: without the frame's own
   * uncertainty that pose_cov and the landmarks' cov add (rebase ()),
   * which a quantity relative to the robot (a landmark's position in its
   * frame) does not have. An anchor's rows are zero. */
  void joint_cov (size_t k, double cov[25]) const;
  /* The heading's variance relative to the map: with anchors, its
   * marginal; without, that of the heading minus the orientation of the
   * landmarks in the state (their least-squares turn about their
   * centroid), 0 with fewer than two (the frame's orientation is then
   * free: a heading error is the frame's). */
  double heading_var_to_map () const;

  /* Constant-velocity prediction over dt seconds. */
  void predict (double dt);
  /* Odometry: a robot-frame increment (forward, left, turn) of the point
   * opt.odo_camera_forward behind the camera replaces the motion model for
   * that interval; velocities follow it over dt. */
  void predict_odometry (double dx, double dy, double dheading, double dt);
  /* One frame of observations: associate, update, add landmarks. */
  SlamFrame update (const std::vector<SlamObservation> & obs);
  /* The scale of the odometry's slip sigmas in use (1: as stated; learnt
   * with opt.odo_slip_adapt) and of the measurements' sigmas the same
   * evidence gives (not applied: what keeps the first honest). */
  double odometry_slip_scale () const {
    return opt.odo_slip_adapt ? std::sqrt (slip_var_) : 1.0;
  }
  double measurement_scale () const;
  /* Forget what was learnt of the slip (its stated values or
   * opt.odo_slip_adapt changed): the scale is 1 again and the evidence
   * gathers afresh from the next odometry. */
  void restart_slip_learning () { slip_reset (); }
  /* opt.meas_slow_share and opt.meas_slow_length; a change marginalises
   * the slow errors' states (each starts again from its prior) */
  void set_slow_errors (double share, double length);

private:
  bool init_ = false;
  bool anchored_ = false;
  std::vector<double> s_;         /* x y th v d w k g, then landmarks */
  std::vector<double> p_;         /* covariance, n x n row-major */
  std::vector<SlamLandmark> lm_;
  std::vector<int> slot_;         /* per landmark: state index, -1 anchor */
  std::vector<Pose2> last_view_;  /* per landmark: pose of counted view */
  std::vector<int> unseen_;       /* per landmark: updates since seen */
  std::vector<int> pass_views_;   /* per landmark: views in this pass */
  /* per landmark: state index of its slow error (range, bearing), -1
   * none; and how much of it is left since it was last seen */
  std::vector<int> bias_slot_;
  std::vector<double> bias_left_;
  int next_id_ = 1;
  /* slip adaptation: dp_[0] = dP / d(slip variance scale), dp_[1] =
   * dP / d(measurement variance scale), n x n like p_; the weighted
   * normal equations of the two scales and the slip variance scale in
   * use */
  std::vector<double> dp_[2];
  double slip_a_[3] = { 0, 0, 0 };  /* A00 A01 A11 */
  double slip_b_[2] = { 0, 0 };
  double slip_var_ = 1;
  void slip_reset ();
  void slip_forget (double distance, double turned);
  bool slip_tracked () const { return dp_[0].size () == p_.size (); }
  void slip_evidence (const cv::Mat & H, const cv::Mat & Sinv,
      const cv::Mat & R, const cv::Mat & nu, const cv::Mat & K);
  double slip_scales (double *meas_var) const;
  /* the update's N x N product, kept from frame to frame (not copied
   * with the filter: each copy has its own) */
  struct UpdateScratch {
    cv::Mat joseph;
    UpdateScratch () = default;
    UpdateScratch (const UpdateScratch &) {}
    UpdateScratch & operator= (const UpdateScratch &) { return *this; }
  } scratch_;
  std::vector<double> joint_gate_;  /* chi-square quantile, 2 m dof */
  double joint_gate_p_ = -1;
  void joseph_update (double *M, const cv::Mat & K, const cv::Mat & HM,
      const cv::Mat & inner);

  size_t n () const { return s_.size (); }
  void init_pose (const Pose2 & p, const double cov[9]);
  /* without anchors, the pose's uncertainty relative to the first pose
   * when the filter was rebased (the map empty, a landmark starting),
   * and that pose: the frame's, reported, not filtered (rebase ()) */
  double frame_cov_[9] = { 0 };
  Pose2 frame_;
  void rebase ();
  void frame_cov_at (double px, double py, double out[9]) const;
  void add_landmark (const SlamObservation & o, SlamLandmark lm);
  void remove_landmark (size_t k);
  /* the slow measurement errors' states (slamlandmarks.cpp) */
  bool slow_errors () const {
    return opt.meas_slow_share > 0 && opt.meas_slow_share < 1;
  }
  void grow_states (int count, double p_var, double meas_var);
  void remove_states (int first, int count);
  void add_bias (size_t k);
  void decay_biases (double distance);
  void drop_biases ();
  void sync_landmarks ();
  void confirm_known ();
  bool relocalise (const std::vector<SlamObservation> & obs, Pose2 * at,
      std::vector<int> *assign, bool *weak) const;
  /* two detections accepted on the given map alone: the landmarks they
   * were paired with, in how many consecutive frames, the last one */
  struct RelocPending {
    int lm[2] = { -1, -1 };
    int frames = 0;
    long frame = -1;
  } reloc_pending_;
  long frame_no_ = 0;             /* update ()s */
  bool reloc_confirmed (const std::vector<int> & assign, bool weak);
  bool first_pose_relocalised (const std::vector<SlamObservation> & obs);

  /* update ()'s steps, in its order */
  struct Pairing;                 /* slaminternal.h */
  void attach_biases (const std::vector<SlamObservation> & obs,
      std::vector<const Pairing *> & best, std::vector<Pairing> & store,
      std::vector<double> & prior);
  bool place_first_pose (const std::vector<SlamObservation> & obs,
      SlamFrame & f);
  bool make_pairing (const std::vector<SlamObservation> & obs, int i, int k,
      const cv::Mat & P, Pairing * pr) const;
  void gate_pairings (const std::vector<SlamObservation> & obs,
      const cv::Mat & P, std::vector<std::vector<Pairing>> & cand) const;
  static double joint_nis (const std::vector<const Pairing *> &h);
  double jcbb (const std::vector<std::vector<Pairing>> & cand,
      std::vector<const Pairing *> & best);
  double pair_relocalised (const std::vector<SlamObservation> & obs,
      const cv::Mat & P, const std::vector<double> & prior,
      std::vector<Pairing> & found, std::vector<const Pairing *> & best);
  void filter_update (const std::vector<const Pairing *> & best,
      const std::vector<double> & prior, const cv::Mat & P,
      bool relocalised);
  void count_views (const SlamFrame & f);
  double matched_residual (const std::vector<SlamObservation> & obs,
      const SlamFrame & f) const;
  void start_landmarks (const std::vector<SlamObservation> & obs,
      SlamFrame & f);
  void drop_unseen (SlamFrame & f);
};

}  // namespace landmark
