// B-mode frame formation, beam by beam (one image column is one beam):
//
//   envelope = | diffuse * z + specular |,  grey = envelope + electronic noise
//
// `diffuse` is the mean echo of the medium the beam is in (water, tissue or
// lumen, attenuated with the tissue depth travelled, shadowed beneath bone),
// `z` the complex speckle of unit mean envelope (Rayleigh: many random
// sub-resolution scatterers), `specular` the coherent echo of single strong
// reflectors (wires, the bone surface) blurred by the PSF. A strong
// reflector inside weak speckle then has the Rician statistics of real
// images: stable, bright, barely speckled. Bone: the first crossing of each
// beam gives a bright band (dimmer at oblique incidence) and the shadow
// beneath; where the crossing jumps between neighbouring beams (the bone's
// edge) the beams are mixed over the lateral PSF, so the shadow's edge is
// blurred as by a real beam's width.
//
// Not modelled: the beam's elevation thickness (a wire parallel to the
// plane is not drawn), reverberation, refraction, speed-of-sound errors,
// time-gain compensation and log compression (grey levels are linear in
// echo amplitude, with the means of BModeNoiseModel).
//
// Cost: the scene's distance functions are sampled on an adaptive lattice
// (bmode_distance_lattice.h), never per pixel; the speckle is a lattice
// field read by interpolation (bmode_speckle.h); per pixel the renderer does
// a few multiply-adds, one square root and half a 64-bit random draw.
#include "mrsns/simulation/bmode_renderer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>
#include <sstream>

#include "bmode_distance_lattice.h"
#include "bmode_speckle.h"
#include "mrsns/core/error.h"

namespace mrsns::simulation {

namespace {

using detail::DistanceLattice;
using detail::SpeckleField;
using detail::SplitMix64;

/// The bright band of a bone surface: specular over this many axial PSF
/// sigmas beyond the first crossing (plus the PSF's own tails on both
/// sides): the periosteum and cortex reflect nearly all the energy.
constexpr double kBoneBandSigmas = 2.0;
/// Beyond the cortex almost nothing comes back (acoustic shadow): the
/// diffuse echo falls off with the PSF's axial profile to this residual.
constexpr double kShadowResidual = 0.02;
/// PSF tails are cut at this many sigmas.
constexpr double kPsfCutSigmas = 4.0;

void requireFinitePositive(double value, const char* what) {
  if (!(std::isfinite(value) && value > 0.0)) {
    std::ostringstream msg;
    msg << "renderBModeFrame: " << what << " must be a finite positive number (got " << value << ")";
    throw InvalidArgumentError(msg.str());
  }
}

void validate(const BModeGeometry& geometry, const BModeNoiseModel& noise) {
  if (geometry.width <= 0 || geometry.height <= 0 || geometry.width > 16384 || geometry.height > 16384) {
    std::ostringstream msg;
    msg << "renderBModeFrame: image size " << geometry.width << " x " << geometry.height
        << " px is not usable (each side must be 1..16384)";
    throw InvalidArgumentError(msg.str());
  }
  requireFinitePositive(geometry.spacing_x_mm, "spacing_x_mm");
  requireFinitePositive(geometry.spacing_y_mm, "spacing_y_mm");
  requireFinitePositive(noise.lateral_psf_mm, "the lateral PSF sigma");
  requireFinitePositive(noise.axial_psf_mm, "the axial PSF sigma");
  if (!(noise.attenuation_db_per_cm >= 0.0) || !(noise.electronic_noise >= 0.0))
    throw InvalidArgumentError("renderBModeFrame: attenuation and electronic noise must be >= 0");
}

/// Cubic smoothstep from 0 (d <= -half_width) to 1 (d >= half_width): the
/// lumen edge blurred by the PSF (a Gaussian edge's 2-98 % rise spans +-2 sigma).
float smoothEdge(float d, float half_width) {
  const float t = std::clamp(0.5f + 0.5f * d / half_width, 0.0f, 1.0f);
  return t * t * (3.0f - 2.0f * t);
}

/// A wire's cross-section with the image plane, as a PSF-blurred dot.
struct WireDot {
  double x_mm = 0.0, y_mm = 0.0;
  double sigma_x_mm = 0.0, sigma_y_mm = 0.0;
};

/// Where each wire crosses the plane z = 0 of the image frame (only the
/// segment a-b; wires parallel to the plane have no single crossing and
/// are left out: the beam's elevation thickness is not modelled).
std::vector<WireDot> wireDots(const EchoScene& scene, const Eigen::Isometry3d& image_T_scene,
                              const BModeNoiseModel& noise) {
  std::vector<WireDot> dots;
  for (const auto& wire : scene.wires) {
    const Eigen::Vector3d a = image_T_scene * wire.a, b = image_T_scene * wire.b;
    const double dz = b.z() - a.z(), length = (b - a).norm();
    if (length <= 0.0 || std::abs(dz) < 1e-6 * length) continue;
    const double t = -a.z() / dz;
    if (t < 0.0 || t > 1.0) continue;
    const Eigen::Vector3d hit = a + t * (b - a);
    // The wire's section widens the dot: a disc of radius r has variance r^2 / 4 per axis.
    const double section_variance = 0.25 * wire.radius_mm * wire.radius_mm;
    dots.push_back({hit.x(), hit.y(), std::sqrt(noise.lateral_psf_mm * noise.lateral_psf_mm + section_variance),
                    std::sqrt(noise.axial_psf_mm * noise.axial_psf_mm + section_variance)});
  }
  return dots;
}

/// The depth interval (mm along the beam) a beam spends in the water bath.
struct DepthInterval {
  double begin = 0.0, end = 0.0;
  [[nodiscard]] bool contains(double y) const { return y >= begin && y < end; }
  [[nodiscard]] double overlapUpTo(double y) const { return std::clamp(y, begin, end) - begin; }
};

/// Slab intersection of the beam (x_mm, depth >= 0) with the bath box.
DepthInterval waterInterval(const std::optional<EchoBox>& bath, const Eigen::Isometry3d& box_T_image, double x_mm) {
  if (!bath) return {};
  const Eigen::Vector3d origin = box_T_image * Eigen::Vector3d(x_mm, 0.0, 0.0);
  const Eigen::Vector3d direction = box_T_image.linear().col(1);
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 3; ++k) {
    const double h = bath->half_extent_mm[k];
    if (std::abs(direction[k]) < 1e-12) {
      if (std::abs(origin[k]) > h) return {};
      continue;
    }
    double ta = (-h - origin[k]) / direction[k], tb = (h - origin[k]) / direction[k];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
  }
  if (t1 <= t0) return {};
  return {t0, t1};
}

/// Everything of one frame the per-beam loop needs.
struct FrameSetup {
  int width = 0, height = 0;
  double sx = 0.0, sy = 0.0;
  std::optional<DistanceLattice> bone, vessel;
  std::vector<int> lattice_row;     ///< per image row: lattice cell along depth
  std::vector<float> lattice_frac;  ///< and the fraction within it
  std::vector<float> tissue_att;    ///< per image row: amplitude after that depth of tissue
  double att_per_mm = 0.0;          ///< amplitude attenuation (nepers per mm of tissue, round trip)
  std::vector<WireDot> dots;
  Eigen::Isometry3d box_T_image = Eigen::Isometry3d::Identity();
};

FrameSetup setupFrame(const EchoScene& scene, const Eigen::Isometry3d& scene_T_image, const BModeGeometry& geometry,
                      const BModeNoiseModel& noise) {
  FrameSetup f;
  f.width = geometry.width;
  f.height = geometry.height;
  f.sx = geometry.spacing_x_mm;
  f.sy = geometry.spacing_y_mm;
  const double width_mm = (f.width - 1) * f.sx, height_mm = (f.height - 1) * f.sy;
  const double blur_mm = 2.0 * std::max(noise.lateral_psf_mm, noise.axial_psf_mm);
  if (scene.bone_distance_mm) f.bone.emplace(scene.bone_distance_mm, scene_T_image, width_mm, height_mm, blur_mm);
  if (scene.vessel_distance_mm) f.vessel.emplace(scene.vessel_distance_mm, scene_T_image, width_mm, height_mm, blur_mm);
  // dB per cm round trip -> amplitude nepers per mm: ln(10) / 20 / 10.
  f.att_per_mm = noise.attenuation_db_per_cm * std::log(10.0) / 200.0;
  const auto rows = static_cast<std::size_t>(f.height);
  f.lattice_row.resize(rows);
  f.lattice_frac.resize(rows);
  f.tissue_att.resize(rows);
  const int lattice_rows = f.bone ? f.bone->rows() : (f.vessel ? f.vessel->rows() : 2);
  for (std::size_t r = 0; r < rows; ++r) {
    const double u = static_cast<double>(r) * f.sy / DistanceLattice::kFineStepMm;
    const int j = std::min(static_cast<int>(u), lattice_rows - 2);
    f.lattice_row[r] = j;
    f.lattice_frac[r] = static_cast<float>(u - j);
    f.tissue_att[r] = static_cast<float>(std::exp(-f.att_per_mm * static_cast<double>(r) * f.sy));
  }
  f.dots = wireDots(scene, scene_T_image.inverse(), noise);
  if (scene.water_bath) f.box_T_image = scene.water_bath->scene_T_box.inverse() * scene_T_image;
  return f;
}

/// One lattice column interpolated laterally to the beam at x_mm.
void latticeColumn(const DistanceLattice& lattice, double x_mm, std::vector<float>& out) {
  const double u = x_mm / DistanceLattice::kFineStepMm;
  const int i = std::min(static_cast<int>(u), lattice.columns() - 2);
  const auto f = static_cast<float>(u - i);
  const float* a = lattice.column(i);
  const float* b = lattice.column(i + 1);
  out.resize(static_cast<std::size_t>(lattice.rows()));
  for (int j = 0; j < lattice.rows(); ++j) out[static_cast<std::size_t>(j)] = a[j] + f * (b[j] - a[j]);
}

/// Depth (mm) of the beam's first entry into bone outside the water bath:
/// the first zero of the piecewise-linear distance along the lattice column.
std::optional<double> firstBoneCrossing(const std::vector<float>& bone, const DepthInterval& water, double max_mm) {
  const double h = DistanceLattice::kFineStepMm;
  for (std::size_t j = 0; j + 1 < bone.size() && static_cast<double>(j) * h <= max_mm; ++j) {
    double y = -1.0;
    if (j == 0 && bone[0] < 0.0f) {
      y = 0.0;
    } else if (bone[j] >= 0.0f && bone[j + 1] < 0.0f) {
      y = (static_cast<double>(j) + bone[j] / (bone[j] - bone[j + 1])) * h;
    } else {
      continue;
    }
    if (y > max_mm) return std::nullopt;
    if (!water.contains(y)) return y;
  }
  return std::nullopt;
}

/// Where a beam enters bone and how much of the specular echo returns.
struct BoneHit {
  double depth_mm = 0.0;
  /// A smooth cortex reflects like a mirror: the echo back along the beam
  /// falls with the angle between beam and surface normal (cos^2 here, the
  /// in-plane angle from the distance's gradient), down to the diffuse
  /// backscatter of a rough surface (kRoughFloor).
  float incidence = 1.0f;
};
constexpr double kRoughFloor = 0.25;

std::optional<BoneHit> boneHit(const DistanceLattice& bone, const std::vector<float>& bone_column, double x_mm,
                               const DepthInterval& water, double max_mm) {
  const auto depth = firstBoneCrossing(bone_column, water, max_mm);
  if (!depth) return std::nullopt;
  constexpr double kDelta = 0.5 * DistanceLattice::kFineStepMm;
  const double gx = bone.at(x_mm + kDelta, *depth) - bone.at(x_mm - kDelta, *depth);
  const double gy = bone.at(x_mm, *depth + kDelta) - bone.at(x_mm, *depth - kDelta);
  const double norm2 = gx * gx + gy * gy;
  const double cos2 = norm2 > 0.0 ? gy * gy / norm2 : 1.0;
  return BoneHit{*depth, static_cast<float>(kRoughFloor + (1.0 - kRoughFloor) * cos2)};
}

/// Amplitude of a Gaussian PSF tail (u in sigmas), 0 beyond the cut.
float gaussianTail(double u) {
  return std::abs(u) > kPsfCutSigmas ? 0.0f : static_cast<float>(std::exp(-0.5 * u * u));
}

/// The bone surface's specular profile along the beam, u = depth - surface (mm).
float boneBand(double u, double sigma) {
  const double thickness = kBoneBandSigmas * sigma;
  if (u < 0.0) return gaussianTail(u / sigma);
  if (u <= thickness) return 1.0f;
  return gaussianTail((u - thickness) / sigma);
}

/// Amplitude attenuation at depth y of a beam that crossed `water` (no loss there).
float attenuationAt(const FrameSetup& f, const DepthInterval& water, double y) {
  return static_cast<float>(std::exp(-f.att_per_mm * (y - water.overlapUpTo(y))));
}

/// Rows [r0, r1] of the image covering depths [from_mm, to_mm].
std::pair<int, int> rowRange(const FrameSetup& f, double from_mm, double to_mm) {
  const int r0 = std::max(0, static_cast<int>(std::floor(from_mm / f.sy)));
  const int r1 = std::min(f.height - 1, static_cast<int>(std::ceil(to_mm / f.sy)));
  return {r0, r1};
}

/// Adds the wire dots' specular echoes on the beam at x_mm to `specular`.
void addWireEchoes(const FrameSetup& f, const BModeNoiseModel& noise, double x_mm, const DepthInterval& water,
                   std::vector<float>& specular) {
  for (const auto& dot : f.dots) {
    const double lateral = (x_mm - dot.x_mm) / dot.sigma_x_mm;
    if (std::abs(lateral) > kPsfCutSigmas) continue;
    const float peak =
        static_cast<float>(noise.wire_echo) * gaussianTail(lateral) * attenuationAt(f, water, std::max(0.0, dot.y_mm));
    const auto [r0, r1] =
        rowRange(f, dot.y_mm - kPsfCutSigmas * dot.sigma_y_mm, dot.y_mm + kPsfCutSigmas * dot.sigma_y_mm);
    for (int r = r0; r <= r1; ++r)
      specular[static_cast<std::size_t>(r)] += peak * gaussianTail((r * f.sy - dot.y_mm) / dot.sigma_y_mm);
  }
}

/// What bone does to every beam: where it enters bone (if it does) and the
/// water it crossed, found once per frame so each beam can see its
/// neighbours' (the lateral PSF blurs the shadow's and the surface's edges).
struct BoneBeams {
  std::vector<std::optional<BoneHit>> hits;  ///< per image column
  std::vector<DepthInterval> water;          ///< per image column
  std::vector<float> lateral_weights;        ///< lateral PSF over neighbouring beams, centre at the middle
  int stride = 1;                            ///< columns between those beams
};

BoneBeams boneBeams(const EchoScene& scene, const FrameSetup& f, const BModeNoiseModel& noise) {
  BoneBeams b;
  const auto columns = static_cast<std::size_t>(f.width);
  b.hits.resize(columns);
  b.water.resize(columns);
  const double depth_mm = (f.height - 1) * f.sy;
  std::vector<float> bone_column;
  for (std::size_t c = 0; c < columns; ++c) {
    const double x = static_cast<double>(c) * f.sx;
    b.water[c] = waterInterval(scene.water_bath, f.box_T_image, x);
    if (!f.bone) continue;
    latticeColumn(*f.bone, x, bone_column);
    b.hits[c] = boneHit(*f.bone, bone_column, x, b.water[c], depth_mm);
  }
  // Beams half a PSF sigma apart sample the lateral PSF well enough.
  b.stride = std::max(1, static_cast<int>(std::lround(0.5 * noise.lateral_psf_mm / f.sx)));
  const double tap_mm = b.stride * f.sx;
  const int reach = static_cast<int>(std::ceil(2.0 * noise.lateral_psf_mm / tap_mm));
  for (int k = -reach; k <= reach; ++k) b.lateral_weights.push_back(gaussianTail(k * tap_mm / noise.lateral_psf_mm));
  float total = 0.0f;
  for (float w : b.lateral_weights) total += w;
  for (float& w : b.lateral_weights) w /= total;
  return b;
}

/// Adds `weight` times one beam's bone profile: the transmission of the
/// diffuse echo (1 above the surface, falling with the axial PSF to the
/// shadow's residual) and the surface's specular band.
void addBoneProfile(const FrameSetup& f, const BModeNoiseModel& noise, const std::optional<BoneHit>& hit,
                    const DepthInterval& water, float weight, std::vector<float>& transmission,
                    std::vector<float>& specular) {
  const auto rows = static_cast<std::size_t>(f.height);
  if (!hit) {
    for (std::size_t r = 0; r < rows; ++r) transmission[r] += weight;
    return;
  }
  const double y = hit->depth_mm, sigma_y = noise.axial_psf_mm;
  // Above the surface: full transmission; within the PSF's reach below it:
  // the falling edge; beyond: the shadow's residual.
  const auto [e0, e1] = rowRange(f, y, y + kPsfCutSigmas * sigma_y);
  const auto edge_begin = static_cast<std::size_t>(std::max(e0, 0)), edge_end = static_cast<std::size_t>(e1 + 1);
  for (std::size_t r = 0; r < std::min(edge_begin, rows); ++r) transmission[r] += weight;
  for (std::size_t r = edge_begin; r < std::min(edge_end, rows); ++r) {
    const double u = std::max(0.0, static_cast<double>(r) * f.sy - y) / sigma_y;
    transmission[r] +=
        weight * (static_cast<float>(kShadowResidual) + static_cast<float>(1.0 - kShadowResidual) * gaussianTail(u));
  }
  const float residual = weight * static_cast<float>(kShadowResidual);
  for (std::size_t r = edge_end; r < rows; ++r) transmission[r] += residual;
  const float peak = weight * static_cast<float>(noise.bone_echo) * hit->incidence * attenuationAt(f, water, y);
  const auto [r0, r1] = rowRange(f, y - kPsfCutSigmas * sigma_y, y + (kBoneBandSigmas + kPsfCutSigmas) * sigma_y);
  for (int r = r0; r <= r1; ++r) specular[static_cast<std::size_t>(r)] += peak * boneBand(r * f.sy - y, sigma_y);
}

/// The bone profile of beam c: its own where its neighbours within the
/// lateral PSF meet bone at the same depth (to a fraction of the axial
/// PSF), else the PSF-weighted mix of theirs.
void boneColumn(const FrameSetup& f, const BModeNoiseModel& noise, const BoneBeams& b, int c,
                std::vector<float>& transmission, std::vector<float>& specular) {
  std::fill(transmission.begin(), transmission.end(), 0.0f);
  const int reach = static_cast<int>(b.lateral_weights.size() / 2);
  const auto& own = b.hits[static_cast<std::size_t>(c)];
  bool uniform = true;
  // Half an axial sigma of depth change within the PSF changes the band
  // by little: the costly mix is for edges and steep surfaces only.
  const int span = reach * b.stride;
  for (int k = std::max(0, c - span); k <= std::min(f.width - 1, c + span) && uniform; ++k) {
    const auto& other = b.hits[static_cast<std::size_t>(k)];
    uniform = other.has_value() == own.has_value() &&
              (!own || std::abs(other->depth_mm - own->depth_mm) < 0.5 * noise.axial_psf_mm);
  }
  if (uniform) {
    addBoneProfile(f, noise, own, b.water[static_cast<std::size_t>(c)], 1.0f, transmission, specular);
    return;
  }
  for (int k = -reach; k <= reach; ++k) {
    const auto n = static_cast<std::size_t>(std::clamp(c + k * b.stride, 0, f.width - 1));
    addBoneProfile(f, noise, b.hits[n], b.water[n], b.lateral_weights[static_cast<std::size_t>(k + reach)],
                   transmission, specular);
  }
}

/// Mean diffuse echo of every row of one beam: water (no loss), else tissue
/// or lumen attenuated by the tissue travelled, times the transmission past
/// bone (`transmission`, null: no bone).
void diffuseColumn(const FrameSetup& f, const BModeNoiseModel& noise, const DepthInterval& water,
                   const std::vector<float>* vessel, const std::vector<float>* transmission,
                   std::vector<float>& diffuse) {
  const float lumen = static_cast<float>(noise.lumen_echo), tissue = static_cast<float>(noise.tissue_echo);
  const float edge = static_cast<float>(2.0 * 0.5 * (noise.lateral_psf_mm + noise.axial_psf_mm));
  // Past the bath the water path is not lost: undo its share of tissue_att.
  const float after_water = static_cast<float>(std::exp(f.att_per_mm * (water.end - water.begin)));
  for (int r = 0; r < f.height; ++r) {
    const auto ru = static_cast<std::size_t>(r);
    const double y = r * f.sy;
    if (water.contains(y)) {
      diffuse[ru] = static_cast<float>(noise.water_echo);
      continue;
    }
    float echo = tissue;
    if (vessel != nullptr) {
      const auto j = static_cast<std::size_t>(f.lattice_row[ru]);
      const float d = (*vessel)[j] + f.lattice_frac[ru] * ((*vessel)[j + 1] - (*vessel)[j]);
      echo = lumen + (tissue - lumen) * smoothEdge(d, edge);
    }
    echo *= f.tissue_att[ru] * (y >= water.end ? after_water : 1.0f);
    if (transmission != nullptr) echo *= (*transmission)[ru];
    diffuse[ru] = echo;
  }
}

}  // namespace

std::vector<std::uint8_t> renderBModeFrame(const EchoScene& scene, const Eigen::Isometry3d& scene_T_image,
                                           const BModeGeometry& geometry, const BModeNoiseModel& noise,
                                           std::uint64_t frame_seed) {
  validate(geometry, noise);
  SplitMix64 rng(frame_seed);
  const FrameSetup f = setupFrame(scene, scene_T_image, geometry, noise);
  std::optional<SpeckleField> speckle;
  if (noise.speckle) speckle.emplace(f.width, f.height, f.sx, f.sy, noise.lateral_psf_mm, noise.axial_psf_mm, rng);

  const auto rows = static_cast<std::size_t>(f.height);
  const BoneBeams beams = boneBeams(scene, f, noise);
  std::vector<float> diffuse(rows), specular(rows), transmission(rows), re(rows, 1.0f), im(rows, 0.0f), grain(rows);
  std::vector<float> vessel_col;
  Eigen::ArrayXf envelope(f.height);
  using Column = Eigen::Map<const Eigen::ArrayXf>;
  std::vector<std::uint8_t> pixels(rows * static_cast<std::size_t>(f.width));
  const auto electronic = static_cast<float>(noise.electronic_noise);
  for (int c = 0; c < f.width; ++c) {
    const double x = c * f.sx;
    const DepthInterval& water = beams.water[static_cast<std::size_t>(c)];
    std::fill(specular.begin(), specular.end(), 0.0f);
    if (f.bone) boneColumn(f, noise, beams, c, transmission, specular);
    if (f.vessel) latticeColumn(*f.vessel, x, vessel_col);
    diffuseColumn(f, noise, water, f.vessel ? &vessel_col : nullptr, f.bone ? &transmission : nullptr, diffuse);
    addWireEchoes(f, noise, x, water, specular);
    if (speckle) speckle->column(c, re, im);
    for (std::size_t r = 0; r + 1 < rows; r += 2) rng.normalPair(grain[r], grain[r + 1]);
    if (rows % 2 == 1) {
      float unused = 0.0f;
      rng.normalPair(grain[rows - 1], unused);
    }
    // Envelope of the diffuse speckle plus the coherent echo, then noise.
    const auto d = Column(diffuse.data(), f.height);
    const auto real = d * Column(re.data(), f.height) + Column(specular.data(), f.height);
    const auto imag = d * Column(im.data(), f.height);
    envelope = (real.square() + imag.square()).sqrt() + electronic * Column(grain.data(), f.height) + 0.5f;
    envelope = envelope.max(0.0f).min(255.0f);  // + 0.5 then truncation: nearest grey level
    std::uint8_t* out = pixels.data() + c;
    for (std::size_t r = 0; r < rows; ++r)
      out[r * static_cast<std::size_t>(f.width)] = static_cast<std::uint8_t>(envelope[static_cast<Eigen::Index>(r)]);
  }
  return pixels;
}

}  // namespace mrsns::simulation
