/* What the SLAM filter's files (slam.cpp, slamassociation.cpp,
 * slamlandmarks.cpp) share: a detection-landmark pairing and the product
 * of a sparse measurement Jacobian. Not for use outside them. */
#pragma once

#include <opencv2/core.hpp>

#include "slam.h"

namespace landmark {

/* A detection-landmark pairing: innovation, Jacobian, P H'. */
struct Slam::Pairing {
  int obs = -1, lm = -1;
  cv::Vec2d nu;
  cv::Mat H;        /* 2 x N */
  /* H's non-zero columns: the pose's, the landmark's, its slow error's */
  int cols[7] = {};
  int n_cols = 0;
  cv::Mat PHt;      /* N x 2 */
  cv::Matx22d R;
  double d2 = 0;    /* individual Mahalanobis distance squared */
};

/* H M for a measurement Jacobian H: each row of H has a few non-zero
 * columns (the pose's and one landmark's), so H M is those rows of M
 * summed, O(rows x N) where the dense product is O(rows x N^2)
 * (slam.cpp) */
cv::Mat jacobian_times (const cv::Mat & H, const cv::Mat & M);

}  // namespace landmark
