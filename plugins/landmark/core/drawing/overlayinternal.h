/* What the overlay drawing files (overlaydraw.cpp, overlayparts.cpp,
 * overlaycomposite.cpp) share: the colours and sizes of the drawing, and
 * small helpers. Not for use outside them. */
#pragma once

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

#include "overlaydraw.h"

namespace landmark {
namespace overlay {
namespace internal {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;
constexpr int kEllipsePoints = 72;
constexpr double kFar = 1e5;          /* coordinates are clamped to this */

constexpr Rgb kBlack { 0, 0, 0 };
constexpr Rgb kWhite { 255, 255, 255 };
constexpr Rgb kGrey { 160, 160, 160 };
constexpr Rgb kMuted { 175, 175, 175 };
constexpr Rgb kDark { 40, 40, 40 };
constexpr Rgb kThreshold { 255, 255, 255 };

inline int
iround (double v)
{
  return (int) std::lround (v);
}

inline double
overlap (const cv::Rect & a, const cv::Rect & b)
{
  return (double) (a & b).area ();
}

}  // namespace internal
}  // namespace overlay
}  // namespace landmark
