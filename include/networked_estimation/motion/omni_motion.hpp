// The motion equations of omni_2d and omni_3d and their Jacobians, written once as templates on the
// vector and matrix types (fixed-size or dynamic), derived in docs/algorithms.md 7.2 and 7.3.
//
// Conventions (REP-103, as robot_localization's state): positions and the Euler angles roll, pitch,
// yaw in the world frame; the body-to-world rotation R = Rz(yaw) Ry(pitch) Rx(roll); the linear
// velocity v, the angular velocity w and the acceleration a in the robot's frame. Over dt, with the
// body-frame displacement d = v dt + a dt^2 / 2 held in the orientation at the start of the step:
//
//   p'     = p + R d
//   angles = angles + E(roll, pitch) w dt        (the Euler-angle rates of a body rate w)
//   v'     = v + a dt,    w' = w,    a' = a
#pragma once

#include <cmath>

namespace networked_estimation
{
namespace omni
{

// omni_2d: [x, y, yaw, vx, vy, vyaw, ax, ay]
namespace s2
{
constexpr int X = 0, Y = 1, YAW = 2, VX = 3, VY = 4, VYAW = 5, AX = 6, AY = 7, N = 8;
}
// omni_3d: [x, y, z, roll, pitch, yaw, vx, vy, vz, vroll, vpitch, vyaw, ax, ay, az]
namespace s3
{
constexpr int X = 0, Y = 1, Z = 2, ROLL = 3, PITCH = 4, YAW = 5, VX = 6, VY = 7, VZ = 8, VROLL = 9, VPITCH = 10,
              VYAW = 11, AX = 12, AY = 13, AZ = 14, N = 15;
}

/// omni_2d: out = f(x, dt); when F is not null, *F = df/dx (F must be 8 x 8; it is overwritten).
///   x'   = x + cos(yaw) dx - sin(yaw) dy        d = v dt + a dt^2/2
///   y'   = y + sin(yaw) dx + cos(yaw) dy
///   yaw' = yaw + vyaw dt,  v' = v + a dt,  vyaw' = vyaw,  a' = a
template <class Vec, class Out, class Jac>
void omni2dStep(const Vec& x, double dt, Out& out, Jac* F)
{
  using namespace s2;
  const double c = std::cos(x[YAW]), s = std::sin(x[YAW]);
  const double h = 0.5 * dt * dt;
  const double dx = x[VX] * dt + x[AX] * h, dy = x[VY] * dt + x[AY] * h;
  const double wx = c * dx - s * dy, wy = s * dx + c * dy;  // R d, the world-frame displacement
  out[X] = x[X] + wx;
  out[Y] = x[Y] + wy;
  out[YAW] = x[YAW] + x[VYAW] * dt;
  out[VX] = x[VX] + x[AX] * dt;
  out[VY] = x[VY] + x[AY] * dt;
  out[VYAW] = x[VYAW];
  out[AX] = x[AX];
  out[AY] = x[AY];
  if (!F)
    return;
  Jac& J = *F;
  J.setIdentity();
  // d(R d)/dyaw = [-wy, wx]
  J(X, YAW) = -wy;
  J(Y, YAW) = wx;
  // d(R d)/dv = R dt, d(R d)/da = R dt^2/2
  J(X, VX) = c * dt;
  J(X, VY) = -s * dt;
  J(Y, VX) = s * dt;
  J(Y, VY) = c * dt;
  J(X, AX) = c * h;
  J(X, AY) = -s * h;
  J(Y, AX) = s * h;
  J(Y, AY) = c * h;
  J(YAW, VYAW) = dt;
  J(VX, AX) = dt;
  J(VY, AY) = dt;
}

/// omni_3d: out = f(x, dt); when F is not null, *F = df/dx (15 x 15, overwritten). The Euler-angle
/// rates are singular at pitch = +-pi/2 (1 / cos(pitch)), as for every roll-pitch-yaw state.
template <class Vec, class Out, class Jac>
void omni3dStep(const Vec& x, double dt, Out& out, Jac* F)
{
  using namespace s3;
  const double cr = std::cos(x[ROLL]), sr = std::sin(x[ROLL]);
  const double cp = std::cos(x[PITCH]), sp = std::sin(x[PITCH]);
  const double cy = std::cos(x[YAW]), sy = std::sin(x[YAW]);
  const double sec = 1.0 / cp, tp = sp * sec;
  // R = Rz(yaw) Ry(pitch) Rx(roll), by rows
  const double r00 = cy * cp, r01 = cy * sp * sr - sy * cr, r02 = cy * sp * cr + sy * sr;
  const double r10 = sy * cp, r11 = sy * sp * sr + cy * cr, r12 = sy * sp * cr - cy * sr;
  const double r20 = -sp, r21 = cp * sr, r22 = cp * cr;
  const double h = 0.5 * dt * dt;
  const double d0 = x[VX] * dt + x[AX] * h, d1 = x[VY] * dt + x[AY] * h, d2 = x[VZ] * dt + x[AZ] * h;
  const double w0 = r00 * d0 + r01 * d1 + r02 * d2;  // R d
  const double w1 = r10 * d0 + r11 * d1 + r12 * d2;
  const double w2 = r20 * d0 + r21 * d1 + r22 * d2;
  const double wr = x[VROLL], wp = x[VPITCH], wyw = x[VYAW];
  const double q = sr * wp + cr * wyw;  // appears in the roll and yaw rates
  out[X] = x[X] + w0;
  out[Y] = x[Y] + w1;
  out[Z] = x[Z] + w2;
  out[ROLL] = x[ROLL] + (wr + tp * q) * dt;
  out[PITCH] = x[PITCH] + (cr * wp - sr * wyw) * dt;
  out[YAW] = x[YAW] + sec * q * dt;
  out[VX] = x[VX] + x[AX] * dt;
  out[VY] = x[VY] + x[AY] * dt;
  out[VZ] = x[VZ] + x[AZ] * dt;
  out[VROLL] = wr;
  out[VPITCH] = wp;
  out[VYAW] = wyw;
  out[AX] = x[AX];
  out[AY] = x[AY];
  out[AZ] = x[AZ];
  if (!F)
    return;
  Jac& J = *F;
  J.setIdentity();
  // position by the angles: the roll derivative of R's columns 1, 2 is (col 2, -col 1); the pitch
  // derivative of R is the matrix below; the yaw derivative of R's rows 0, 1, 2 is (-row 1, row 0, 0)
  J(X, ROLL) = (r02 * d1 - r01 * d2);
  J(Y, ROLL) = (r12 * d1 - r11 * d2);
  J(Z, ROLL) = (r22 * d1 - r21 * d2);
  J(X, PITCH) = cy * (-sp * d0 + cp * sr * d1 + cp * cr * d2);
  J(Y, PITCH) = sy * (-sp * d0 + cp * sr * d1 + cp * cr * d2);
  J(Z, PITCH) = -cp * d0 - sp * sr * d1 - sp * cr * d2;
  J(X, YAW) = -w1;
  J(Y, YAW) = w0;
  // position by the velocity (R dt) and the acceleration (R dt^2/2)
  const double rot[3][3] = {{r00, r01, r02}, {r10, r11, r12}, {r20, r21, r22}};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
    {
      J(X + i, VX + j) = rot[i][j] * dt;
      J(X + i, AX + j) = rot[i][j] * h;
    }
  // the angles by the angles: d(E w)/droll and d(E w)/dpitch, times dt
  const double qr = cr * wp - sr * wyw;  // dq/droll
  J(ROLL, ROLL) = 1.0 + tp * qr * dt;
  J(ROLL, PITCH) = sec * sec * q * dt;
  J(PITCH, ROLL) = -q * dt;
  J(YAW, ROLL) = sec * qr * dt;
  J(YAW, PITCH) = sec * tp * q * dt;
  // the angles by the body rates: E dt
  J(ROLL, VROLL) = dt;
  J(ROLL, VPITCH) = sr * tp * dt;
  J(ROLL, VYAW) = cr * tp * dt;
  J(PITCH, VPITCH) = cr * dt;
  J(PITCH, VYAW) = -sr * dt;
  J(YAW, VPITCH) = sr * sec * dt;
  J(YAW, VYAW) = cr * sec * dt;
  // velocity by the acceleration
  J(VX, AX) = dt;
  J(VY, AY) = dt;
  J(VZ, AZ) = dt;
}

}  // namespace omni
}  // namespace networked_estimation
