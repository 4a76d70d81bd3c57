// The deforming soft tissue: seeded sinusoidal shape coefficients, the
// surface rebuilt at 10 Hz of scenario time for the echo scene's queries.
#include "mrsns/simulation/soft_tissue.h"

#include <cmath>
#include <nlohmann/json.hpp>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/units.h"

namespace mrsns::simulation {

namespace {
constexpr double kRebuildInterval_s = 0.1;
}  // namespace

DeformingSoftTissue::DeformingSoftTissue(ShapeModel model, const SoftTissueSpec& spec, std::uint64_t seed)
    : model_(std::move(model)), spec_(spec) {
  if (model_.reference.faceCount() == 0 || model_.mean.size() != 3 * model_.reference.vertexCount() ||
      model_.basis.rows() != model_.mean.size() || model_.variances.size() != model_.basis.cols()) {
    throw InvalidArgumentError("the soft tissue's shape model has no surface or sizes that disagree (" +
                               spec.shape_model.string() + ")");
  }
  if (spec_.modes > model_.modeCount()) {
    throw FormatError("patient.soft_tissue.modes is " + std::to_string(spec_.modes) + " but " +
                      spec.shape_model.string() + " has " + std::to_string(model_.modeCount()) + " modes");
  }
  if (static_cast<Eigen::Index>(spec_.push_sd.size()) > model_.modeCount()) {
    throw FormatError("patient.soft_tissue.push.sd has " + std::to_string(spec_.push_sd.size()) + " values but " +
                      spec.shape_model.string() + " has " + std::to_string(model_.modeCount()) + " modes");
  }
  std::mt19937_64 rng(seed * 104729ULL + 11ULL);
  std::uniform_real_distribution<double> factor(0.7, 1.3), phase(0.0, kTwoPi);
  frequency_factor_.resize(spec_.modes);
  phase_.resize(spec_.modes);
  for (int i = 0; i < spec_.modes; ++i) {
    frequency_factor_[i] = factor(rng);
    phase_[i] = phase(rng);
  }
}

Eigen::VectorXd DeformingSoftTissue::coefficients(double t) const {
  Eigen::VectorXd alpha = Eigen::VectorXd::Zero(model_.modeCount());
  for (int i = 0; i < spec_.modes; ++i) {
    alpha[i] = spec_.amplitude_sd * std::sin(kTwoPi * t / (spec_.period_s * frequency_factor_[i]) + phase_[i]);
  }
  if (!spec_.push_sd.empty() && t > spec_.push_start_s) {
    // Smoothstep: the tissue starts and ends the push at rest.
    const double u = std::min(1.0, (t - spec_.push_start_s) / spec_.push_ramp_s);
    const double ramp = u * u * (3.0 - 2.0 * u);
    for (std::size_t i = 0; i < spec_.push_sd.size(); ++i) alpha[static_cast<Eigen::Index>(i)] += ramp * spec_.push_sd[i];
  }
  return alpha;
}

Eigen::MatrixXd DeformingSoftTissue::verticesAt(double t) const {
  const Eigen::VectorXd shape =
      model_.mean + model_.basis * (model_.variances.cwiseMax(0.0).cwiseSqrt().asDiagonal() * coefficients(t));
  Eigen::MatrixXd v(model_.reference.vertexCount(), 3);
  for (Eigen::Index i = 0; i < v.rows(); ++i) v.row(i) = shape.segment<3>(3 * i).transpose();
  return v;
}

std::shared_ptr<const MeshLocator> DeformingSoftTissue::surfaceAt(double t) const {
  const auto bucket = static_cast<long long>(std::floor(t / kRebuildInterval_s));
  std::lock_guard lock(mutex_);
  if (bucket != cached_bucket_ || !cached_) {
    TriangleMesh mesh = model_.reference;
    mesh.vertices = verticesAt(bucket * kRebuildInterval_s);
    mesh.normals.resize(0, 3);
    cached_ = std::make_shared<const MeshLocator>(mesh);
    cached_bucket_ = bucket;
  }
  return cached_;
}

std::string DeformingSoftTissue::truthJson() const {
  nlohmann::json j;
  j["shape_model"] = spec_.shape_model.string();
  nlohmann::json m = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m.push_back(spec_.ct_T_model.matrix()(r, c));
  }
  j["ModelToCT"] = m;
  j["formula"] =
      "alpha_i(t) = amplitude_sd * sin(2 pi t / (period_s * frequency_factor_i) + phase_i) + push_sd_i * s(u), "
      "u = clamp((t - push_start_s) / push_ramp_s, 0, 1), s(u) = u^2 (3 - 2u); t in s since utc_start; "
      "shape = mean + basis * diag(sqrt(variances)) * alpha";
  j["push_sd"] = spec_.push_sd;
  j["push_start_s"] = spec_.push_start_s;
  j["push_ramp_s"] = spec_.push_ramp_s;
  j["amplitude_sd"] = spec_.amplitude_sd;
  j["period_s"] = spec_.period_s;
  j["frequency_factor"] =
      std::vector<double>(frequency_factor_.data(), frequency_factor_.data() + frequency_factor_.size());
  j["phase"] = std::vector<double>(phase_.data(), phase_.data() + phase_.size());
  return j.dump();
}

}  // namespace mrsns::simulation
