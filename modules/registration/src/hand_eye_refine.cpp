// Non-linear refinement of AX = XB and AX = YB by Levenberg-Marquardt with
// numerical Jacobians (6 or 12 parameters: small enough that Ceres would add a
// dependency and no accuracy).
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <functional>

#include "hand_eye_internal.h"
#include "mrsns/core/rigid.h"

namespace mrsns::hand_eye_detail {
namespace {

using Residuals = std::function<Eigen::VectorXd(const Eigen::VectorXd&)>;

// Minimises |f(p)|^2 from p = 0; returns the iterations run.
int levenbergMarquardt(const Residuals& f, Eigen::VectorXd& p) {
  const Eigen::Index m = p.size();
  Eigen::VectorXd r = f(p);
  double cost = r.squaredNorm();
  double lambda = 1e-3;
  int iteration = 0;
  for (; iteration < 100; ++iteration) {
    Eigen::MatrixXd J(r.size(), m);
    for (Eigen::Index k = 0; k < m; ++k) {
      constexpr double h = 1e-7;
      Eigen::VectorXd plus = p, minus = p;
      plus(k) += h;
      minus(k) -= h;
      J.col(k) = (f(plus) - f(minus)) / (2.0 * h);
    }
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * r;
    bool improved = false;
    for (int attempt = 0; attempt < 20 && !improved; ++attempt) {
      Eigen::MatrixXd H = JtJ;
      H.diagonal() += lambda * JtJ.diagonal().cwiseMax(1e-12);
      const Eigen::VectorXd step = -H.ldlt().solve(g);
      const Eigen::VectorXd candidate = p + step;
      const Eigen::VectorXd r_new = f(candidate);
      const double cost_new = r_new.squaredNorm();
      if (std::isfinite(cost_new) && cost_new < cost) {
        const double decrease = cost - cost_new;
        p = candidate;
        r = r_new;
        cost = cost_new;
        lambda = std::max(lambda / 10.0, 1e-12);
        improved = true;
        if (step.norm() < 1e-12 || decrease <= 1e-14 * (cost + 1e-300)) return iteration + 1;
      } else {
        lambda *= 10.0;
      }
    }
    if (!improved) break;
  }
  return iteration;
}

// X perturbed by p = [phi; rho]: rotation left-multiplied by exp(phi), translation shifted.
Eigen::Isometry3d perturb(const Eigen::Isometry3d& X, const Eigen::Ref<const Eigen::VectorXd>& p) {
  Eigen::Isometry3d out = Eigen::Isometry3d::Identity();
  out.linear() = so3Exp(p.head<3>()) * X.linear();
  out.translation() = X.translation() + p.tail<3>();
  return out;
}

double rms(const std::vector<double>& v) {
  double s = 0.0;
  for (double x : v) s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

// Per-pair rotation (rad) and translation (mm) discrepancies between L_i and R_i.
void discrepancies(const Poses& L, const Poses& R, std::vector<double>& rot, std::vector<double>& trans) {
  rot.clear();
  trans.clear();
  for (size_t i = 0; i < L.size(); ++i) {
    rot.push_back(rotationAngleBetween(L[i].linear(), R[i].linear()));
    trans.push_back((L[i].translation() - R[i].translation()).norm());
  }
}

// Residual vector of pairs L_i ~ R_i, each part divided by its scale (rad, mm): an
// approximate maximum-likelihood weighting when the scales are the noise levels.
Eigen::VectorXd stackedResiduals(const Poses& L, const Poses& R, double rot_scale, double trans_scale) {
  Eigen::VectorXd r(6 * static_cast<Eigen::Index>(L.size()));
  for (size_t i = 0; i < L.size(); ++i) {
    const auto k = 6 * static_cast<Eigen::Index>(i);
    r.segment<3>(k) = so3Log(L[i].linear() * R[i].linear().transpose()) / rot_scale;
    r.segment<3>(k + 3) = (L[i].translation() - R[i].translation()) / trans_scale;
  }
  return r;
}

// Scales from the starting point's residuals, floored so exact data does not divide by zero.
void scalesFrom(const Poses& L, const Poses& R, double& rot_scale, double& trans_scale) {
  std::vector<double> rot, trans;
  discrepancies(L, R, rot, trans);
  rot_scale = std::max(rms(rot), 1e-9);
  trans_scale = std::max(rms(trans), 1e-6);
}

}  // namespace

int refineAXXB(const Poses& A, const Poses& B, Eigen::Isometry3d& X) {
  const Eigen::Isometry3d X0 = X;
  auto sides = [&](const Eigen::Isometry3d& x, Poses& L, Poses& R) {
    L.resize(A.size());
    R.resize(A.size());
    for (size_t i = 0; i < A.size(); ++i) {
      L[i] = A[i] * x;
      R[i] = x * B[i];
    }
  };
  Poses L, R;
  sides(X0, L, R);
  double rot_scale = 1.0, trans_scale = 1.0;
  scalesFrom(L, R, rot_scale, trans_scale);
  const Residuals f = [&](const Eigen::VectorXd& p) {
    Poses l, r;
    sides(perturb(X0, p), l, r);
    return stackedResiduals(l, r, rot_scale, trans_scale);
  };
  Eigen::VectorXd p = Eigen::VectorXd::Zero(6);
  const int iterations = levenbergMarquardt(f, p);
  X = perturb(X0, p);
  return iterations;
}

void refineAXYB(const Poses& H, const Poses& W, Eigen::Isometry3d& X, Eigen::Isometry3d& Y) {
  const Eigen::Isometry3d X0 = X, Y0 = Y;
  auto sides = [&](const Eigen::Isometry3d& x, const Eigen::Isometry3d& y, Poses& L, Poses& R) {
    L.resize(H.size());
    R.resize(H.size());
    for (size_t i = 0; i < H.size(); ++i) {
      L[i] = H[i] * x;
      R[i] = y * W[i];
    }
  };
  Poses L, R;
  sides(X0, Y0, L, R);
  double rot_scale = 1.0, trans_scale = 1.0;
  scalesFrom(L, R, rot_scale, trans_scale);
  const Residuals f = [&](const Eigen::VectorXd& p) {
    Poses l, r;
    sides(perturb(X0, p.head<6>()), perturb(Y0, p.tail<6>()), l, r);
    return stackedResiduals(l, r, rot_scale, trans_scale);
  };
  Eigen::VectorXd p = Eigen::VectorXd::Zero(12);
  levenbergMarquardt(f, p);
  X = perturb(X0, p.head<6>());
  Y = perturb(Y0, p.tail<6>());
}

}  // namespace mrsns::hand_eye_detail
