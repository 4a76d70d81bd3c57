#pragma once
// Signed-distance primitives and the cervical vertebra model of the phantom
// (private to phantom_*.cpp).
#include <Eigen/Core>
#include <algorithm>
#include <cmath>

namespace mrsns::registration::phantom {

/// Distance to a capsule (segment a-b, radius r); negative inside.
inline double capsule(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r) {
  const Eigen::Vector3d ab = b - a;
  const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * ab)).norm() - r;
}

/// Approximate distance to an ellipsoid (exact on the axes); negative inside.
inline double ellipsoid(const Eigen::Vector3d& p, const Eigen::Vector3d& c, const Eigen::Vector3d& radii) {
  const Eigen::Vector3d q = (p - c).cwiseQuotient(radii);
  return (q.norm() - 1.0) * radii.minCoeff();
}

/// Elliptic cylinder along z (half axes ax, ay, half height h) with edges rounded by `round`.
inline double roundedEllipticCylinder(const Eigen::Vector3d& p, double ax, double ay, double h, double round) {
  const double ex = p.x() / (ax - round);
  const double ey = p.y() / (ay - round);
  const double radial = (std::sqrt(ex * ex + ey * ey) - 1.0) * (std::min(ax, ay) - round);
  const double axial = std::abs(p.z()) - (h - round);
  const double outside = std::hypot(std::max(radial, 0.0), std::max(axial, 0.0));
  return outside + std::min(std::max(radial, axial), 0.0) - round;
}

/// Polynomial smooth minimum: blends two surfaces over a width of about k mm
/// (the fillets between body, pedicles and processes).
inline double smoothUnion(double a, double b, double k) {
  const double h = std::max(k - std::abs(a - b), 0.0) / k;
  return std::min(a, b) - h * h * k * 0.25;
}

/// Dimensions of one cervical vertebra, level 0 = C3 .. 4 = C7, after
/// published morphometry (Panjabi et al., Spine 1991; pedicle convergence
/// ~45 deg: Karaikovic et al., Spine 1997): body 15.6-18.8 mm wide, 15-16.6
/// mm deep, 13-14.6 mm high; canal ~22-24 mm wide and 13 mm deep; pedicles
/// ~5.4 mm thick; spinous process 13-27 mm long (C7 the longest).
struct VertebraShape {
  double body_ax, body_ay, body_h;
  double canal_y, canal_ax, canal_ay;
  Eigen::Vector3d pedicle_a,
      pedicle_b;  ///< medial-anterior (body) and lateral-posterior (lateral mass) ends, left side
  double pedicle_r;
  Eigen::Vector3d lateral_mass_c, lateral_mass_r;  ///< left side
  Eigen::Vector3d lamina_a, lamina_b;              ///< left lateral end, midline end
  double lamina_r;
  Eigen::Vector3d spinous_a, spinous_b;
  double spinous_r;
  Eigen::Vector3d tp_anterior_a, tp_posterior_a, tp_tip;  ///< transverse process roots and tip, left side
  double tp_r;

  explicit VertebraShape(int level) {
    const double t = level;
    body_ax = 7.8 + 0.4 * t;
    body_ay = 7.5 + 0.2 * t;
    body_h = 6.5 + 0.2 * t;
    canal_ay = 6.5;
    canal_ax = 11.0 + 0.3 * t;
    canal_y = body_ay + canal_ay;
    pedicle_a = Eigen::Vector3d(body_ax - 2.5, body_ay - 2.5, 0.0);
    pedicle_b = Eigen::Vector3d(canal_ax + 2.5, canal_y - 1.0, 0.0);
    pedicle_r = 2.7;
    lateral_mass_c = Eigen::Vector3d(canal_ax + 4.0, canal_y + 1.5, 0.0);
    lateral_mass_r = Eigen::Vector3d(5.0, 6.0, body_h + 1.0);
    lamina_a = Eigen::Vector3d(canal_ax + 2.0, canal_y + 5.0, -1.0);
    lamina_b = Eigen::Vector3d(0.0, canal_y + canal_ay + 3.0, -2.0);
    lamina_r = 2.2;
    const double spinous_length = 13.0 + 2.5 * t + (level == 4 ? 4.0 : 0.0);
    spinous_a = Eigen::Vector3d(0.0, canal_y + canal_ay + 2.0, -2.0);
    spinous_b = spinous_a + Eigen::Vector3d(0.0, spinous_length, -0.35 * spinous_length);
    spinous_r = 2.6;
    tp_anterior_a = Eigen::Vector3d(body_ax - 1.0, 1.5, 0.0);
    tp_posterior_a = Eigen::Vector3d(canal_ax + 3.0, canal_y, 0.0);
    tp_tip = Eigen::Vector3d(canal_ax + 12.0, 6.0, -1.0);
    tp_r = 2.3;
  }

  /// Local extent (for culling): a box that holds every primitive.
  [[nodiscard]] Eigen::Vector3d boxMin() const {
    return Eigen::Vector3d(-(tp_tip.x() + tp_r + 2.0), -(body_ay + 2.0),
                           spinous_b.z() - spinous_r - lateral_mass_r.z() - 2.0);
  }
  [[nodiscard]] Eigen::Vector3d boxMax() const {
    return Eigen::Vector3d(tp_tip.x() + tp_r + 2.0, spinous_b.y() + spinous_r + 2.0, lateral_mass_r.z() + 2.0);
  }

  /// Signed distance in the vertebra frame (mm).
  [[nodiscard]] double distance(const Eigen::Vector3d& p_local) const {
    constexpr double k = 1.2;
    // Mirror to the left side: the vertebra is symmetric about x = 0.
    const Eigen::Vector3d q(std::abs(p_local.x()), p_local.y(), p_local.z());
    double d = roundedEllipticCylinder(p_local, body_ax, body_ay, body_h, 1.5);
    d = smoothUnion(d, capsule(q, pedicle_a, pedicle_b, pedicle_r), k);
    d = smoothUnion(d, ellipsoid(q, lateral_mass_c, lateral_mass_r), k);
    d = smoothUnion(d, capsule(q, lamina_a, lamina_b, lamina_r), k);
    d = smoothUnion(d, capsule(p_local, spinous_a, spinous_b, spinous_r), k);
    d = smoothUnion(d, capsule(q, tp_anterior_a, tp_tip, tp_r), k);
    d = smoothUnion(d, capsule(q, tp_posterior_a, tp_tip, tp_r), k);
    return d;
  }
};

}  // namespace mrsns::registration::phantom
