/* A ground robot's constant-velocity motion: see groundmotion.h. */
#include "groundmotion.h"

#include <algorithm>
#include <cmath>

#include "posesolver.h"

namespace landmark {

namespace {

constexpr int N = kMotionStates;

/* Adds to Q the effect over dt of a white acceleration of intensity q
 * along the unit direction (ex, ey) of the position, integrated from the
 * rate with index `rate` (or into the position alone when rate < 0):
 * position blocks dt^3/3, cross terms dt^2/2, rate dt. */
void
add_white_acceleration (double Q[N * N], double dt, double q, double ex,
    double ey, int rate)
{
  const double e[2] = { ex, ey };
  for (int i = 0; i < 2; i++) {
    for (int j = i; j < 2; j++) {
      const double qij = q * dt * dt * dt / 3 * e[i] * e[j];
      Q[i * N + j] += qij;
      if (j != i)
        Q[j * N + i] += qij;
    }
    if (rate >= 0) {
      Q[i * N + rate] += q * dt * dt / 2 * e[i];
      Q[rate * N + i] += q * dt * dt / 2 * e[i];
    }
  }
  if (rate >= 0)
    Q[rate * N + rate] += q * dt;
}

}  // namespace

GroundMotionStep
ground_motion_predict (const double s[kMotionStates], double dt,
    const GroundMotionNoise & noise)
{
  GroundMotionStep out;
  std::copy (s, s + N, out.s);
  std::fill (out.F, out.F + N * N, 0.0);
  std::fill (out.Q, out.Q + N * N, 0.0);
  for (int i = 0; i < N; i++)
    out.F[i * N + i] = 1;
  if (!(dt > 0))
    return out;

  const double v = s[kMotionSpeed], d = s[kMotionOffset],
      w = s[kMotionTurnRate];
  /* the camera's velocity, at the heading of the interval's middle: v
   * forward and w d sideways */
  const double mid = s[kMotionHeading] + 0.5 * w * dt;
  const double fx = std::cos (mid), fy = std::sin (mid);
  const double side = w * d;
  const double vx = v * fx - side * fy, vy = v * fy + side * fx;
  out.s[kMotionX] += vx * dt;
  out.s[kMotionY] += vy * dt;
  out.s[kMotionHeading] = wrap_angle (s[kMotionHeading] + w * dt);

  /* derivatives of the displacement (vx dt, vy dt): rotating it by a
   * change of the heading turns (vx, vy) into (-vy, vx); the turn rate
   * acts through the middle heading (dt / 2) and the sideways speed */
  double *F = out.F;
  const int X = kMotionX, Y = kMotionY;
  F[X * N + kMotionHeading] = -vy * dt;
  F[Y * N + kMotionHeading] = vx * dt;
  F[X * N + kMotionSpeed] = fx * dt;
  F[Y * N + kMotionSpeed] = fy * dt;
  F[X * N + kMotionOffset] = -w * fy * dt;
  F[Y * N + kMotionOffset] = w * fx * dt;
  F[X * N + kMotionTurnRate] = -vy * dt * dt / 2 - d * fy * dt;
  F[Y * N + kMotionTurnRate] = vx * dt * dt / 2 + d * fx * dt;
  F[kMotionHeading * N + kMotionTurnRate] = dt;

  /* forward acceleration feeds the speed; sideways slip moves only the
   * position; the turn rate's change feeds heading and turn rate (the
   * same dt^3/3, dt^2/2, dt pattern with the heading as "position") */
  const double qf = noise.accel_sigma * noise.accel_sigma;
  const double ql = noise.lateral_sigma * noise.lateral_sigma;
  const double qw = noise.alpha_sigma * noise.alpha_sigma;
  add_white_acceleration (out.Q, dt, qf, fx, fy, kMotionSpeed);
  add_white_acceleration (out.Q, dt, ql, -fy, fx, -1);
  double *Q = out.Q;
  const int H = kMotionHeading, W = kMotionTurnRate;
  Q[H * N + H] += qw * dt * dt * dt / 3;
  Q[H * N + W] += qw * dt * dt / 2;
  Q[W * N + H] += qw * dt * dt / 2;
  Q[W * N + W] += qw * dt;
  Q[kMotionOffset * N + kMotionOffset] +=
      noise.offset_drift * noise.offset_drift * dt;
  return out;
}

}  // namespace landmark
