// The cervical phantom volume: vertebrae from phantom_anatomy.h placed along a
// lordotic curve, soft tissue, trachea, a carotid-like vessel and titanium
// fiducial screws, with partial-volume edges and seeded Gaussian noise.
#include "mrsns/registration/phantom_cervical.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <limits>
#include <numbers>
#include <random>

#include "mrsns/core/error.h"
#include "mrsns/core/parallel.h"
#include "mrsns/registration/label_names.h"
#include "phantom_anatomy.h"

namespace mrsns::registration {
namespace {

using phantom::VertebraShape;
using D = PhantomDensities;

constexpr int kFirstLevelLabel = 3;  // C3
constexpr int kLevels = 5;           // C3..C7
constexpr double kLevelPitchMm = 19.0;
constexpr double kTracheaRadiusMm = 7.5;
const Eigen::Vector3d kTracheaCenter(0.0, -30.0, 0.0);
const Eigen::Vector2d kNeckSemiAxes(52.0, 54.0);

struct PlacedVertebra {
  PhantomVertebra info;
  VertebraShape shape;
  Eigen::AlignedBox3d bounds;
  [[nodiscard]] Eigen::Vector3d toLocal(const Eigen::Vector3d& p) const {
    return info.rotation.transpose() * (p - info.body_center);
  }
  [[nodiscard]] Eigen::Vector3d toWorld(const Eigen::Vector3d& local) const {
    return info.body_center + info.rotation * local;
  }
  [[nodiscard]] double distance(const Eigen::Vector3d& p) const { return shape.distance(toLocal(p)); }
};

struct PlacedScrew {
  Eigen::Vector3d tip, shoulder, head;  ///< shaft tip..shoulder (r 1), head shoulder..head (r 1.75)
  Eigen::AlignedBox3d bounds;
};

/// Flat-ended cylinder from a to b with radius r; negative inside.
double cylinder(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r) {
  const Eigen::Vector3d ab = b - a;
  const double length = ab.norm();
  const Eigen::Vector3d axis = ab / length;
  const double s = (p - a).dot(axis);
  const double radial = (p - a - s * axis).norm() - r;
  const double axial = std::max(-s, s - length);
  return std::hypot(std::max(radial, 0.0), std::max(axial, 0.0)) + std::min(std::max(radial, axial), 0.0);
}

double occupancy(double distance, double h) {
  return std::clamp(0.5 - distance / h, 0.0, 1.0);
}

std::vector<PlacedVertebra> placeVertebrae() {
  std::vector<PlacedVertebra> out;
  for (int level = 0; level < kLevels; ++level) {
    // Cervical lordosis: the mid-cervical bodies lie ~3 mm anterior of C3/C7,
    // and each vertebra is tilted along the curve (about 8 deg at the ends).
    const double z = kLevelPitchMm * (2 - level);
    const double y = -5.0 - 3.0 * (1.0 - (z / 40.0) * (z / 40.0));
    const double slope = 6.0 * z / 1600.0;
    const Eigen::Vector3d ez = Eigen::Vector3d(0.0, slope, 1.0).normalized();
    const Eigen::Vector3d ex = Eigen::Vector3d::UnitX();
    const Eigen::Vector3d ey = ez.cross(ex);
    PlacedVertebra v{PhantomVertebra{}, VertebraShape(level), Eigen::AlignedBox3d()};
    v.info.label = kFirstLevelLabel + level;
    v.info.name = labelInfo(v.info.label, LabelScheme::Verse).name;
    v.info.rotation.col(0) = ex;
    v.info.rotation.col(1) = ey;
    v.info.rotation.col(2) = ez;
    v.info.body_center = Eigen::Vector3d(0.0, y, z);
    const Eigen::Vector3d lo = v.shape.boxMin();
    const Eigen::Vector3d hi = v.shape.boxMax();
    for (int c = 0; c < 8; ++c) {
      const Eigen::Vector3d corner((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(), (c & 4) ? hi.z() : lo.z());
      v.bounds.extend(v.toWorld(corner));
    }
    out.push_back(v);
  }
  return out;
}

double boneDistance(const std::vector<PlacedVertebra>& vertebrae, const Eigen::Vector3d& p) {
  double d = std::numeric_limits<double>::infinity();
  for (const auto& v : vertebrae) d = std::min(d, v.distance(p));
  return d;
}

/// Where the ray p + s * dir (s >= 0, p inside) leaves the surface of `distance`.
template <typename Distance>
Eigen::Vector3d exitPoint(const Distance& distance, const Eigen::Vector3d& p, const Eigen::Vector3d& dir) {
  if (distance(p) >= 0.0) throw ComputationError("phantom construction: a ray start lies outside the bone");
  double inside = 0.0;
  double outside = 0.0;
  for (double s = 0.05; s < 60.0; s += 0.05) {
    if (distance(p + s * dir) >= 0.0) {
      outside = s;
      break;
    }
    inside = s;
  }
  if (outside == 0.0) throw ComputationError("phantom construction: a ray never leaves the bone");
  for (int it = 0; it < 40; ++it) {
    const double mid = 0.5 * (inside + outside);
    (distance(p + mid * dir) < 0.0 ? inside : outside) = mid;
  }
  return p + 0.5 * (inside + outside) * dir;
}

struct ScrewSite {
  int level;
  bool lamina;  ///< lamina or lateral mass
  double side;  ///< +1 left, -1 right
};

void placeScrews(const std::vector<PlacedVertebra>& vertebrae, CervicalPhantom& phantom,
                 std::vector<PlacedScrew>& placed) {
  // Two screws on each of C3, C4, C6 and C7, away from the C5/C6 pedicle
  // entries and spread in three dimensions (a well-conditioned fiducial set).
  const std::array<ScrewSite, 8> sites = {ScrewSite{0, true, 1.0},   ScrewSite{0, true, -1.0}, ScrewSite{1, false, 1.0},
                                          ScrewSite{1, false, -1.0}, ScrewSite{3, true, 1.0},  ScrewSite{3, true, -1.0},
                                          ScrewSite{4, false, 1.0},  ScrewSite{4, false, -1.0}};
  auto bone = [&vertebrae](const Eigen::Vector3d& p) { return boneDistance(vertebrae, p); };
  for (std::size_t i = 0; i < sites.size(); ++i) {
    const ScrewSite& site = sites[i];
    const PlacedVertebra& v = vertebrae[static_cast<std::size_t>(site.level)];
    const auto& shape = v.shape;
    Eigen::Vector3d anchor =
        site.lamina ? Eigen::Vector3d(0.5 * (shape.lamina_a + shape.lamina_b)) : Eigen::Vector3d(shape.lateral_mass_c);
    anchor.x() *= site.side;
    const Eigen::Vector3d dir_local =
        site.lamina ? Eigen::Vector3d(site.side * 0.35, 1.0, 0.3) : Eigen::Vector3d(site.side * 0.5, 1.0, 0.15);
    const Eigen::Vector3d axis = v.info.rotation * dir_local.normalized();
    PhantomFiducialScrew screw;
    screw.label = "F-" + std::to_string(i + 1);
    screw.vertebra = v.info.name;
    screw.axis = axis;
    screw.bone_entry = exitPoint(bone, v.toWorld(anchor), axis);
    screw.tip = screw.bone_entry - 4.5 * axis;
    screw.head = screw.bone_entry + 2.5 * axis;
    PlacedScrew p{screw.tip, screw.bone_entry + 1.0 * axis, screw.head, Eigen::AlignedBox3d()};
    const double margin = 0.5 * screw.head_diameter_mm + 2.0;
    p.bounds.extend(screw.tip);
    p.bounds.extend(screw.head);
    p.bounds.min().array() -= margin;
    p.bounds.max().array() += margin;
    placed.push_back(p);
    Landmark landmark;
    landmark.label = screw.label;
    landmark.position = screw.bone_entry;
    landmark.description =
        screw.vertebra + (site.lamina ? " lamina " : " lateral mass ") + (site.side > 0 ? "left" : "right");
    phantom.fiducials_truth.points.push_back(landmark);
    phantom.screws.push_back(screw);
  }
}

void planPedicleScrews(const std::vector<PlacedVertebra>& vertebrae, CervicalPhantom& phantom) {
  for (int level : {2, 3}) {  // C5, C6
    const PlacedVertebra& v = vertebrae[static_cast<std::size_t>(level)];
    auto distance = [&v](const Eigen::Vector3d& p) { return v.distance(p); };
    for (double side : {1.0, -1.0}) {
      const Eigen::Vector3d mirror(side, 1.0, 1.0);
      const Eigen::Vector3d a = v.toWorld(v.shape.pedicle_a.cwiseProduct(mirror));
      const Eigen::Vector3d b = v.toWorld(v.shape.pedicle_b.cwiseProduct(mirror));
      const Eigen::Vector3d u = (a - b).normalized();  // along the pedicle, posterior-lateral to anterior-medial
      ScrewPath path;
      path.vertebra = v.info.name;
      path.name = path.vertebra + (side > 0 ? " left" : " right");
      path.diameter_mm = 3.5;
      path.entry = exitPoint(distance, b, -u);
      // The tip stops 3 mm short of the mid-sagittal plane (so the left and
      // right screws, 3.5 mm thick, stay 2.5 mm apart) or 3 mm short of the
      // body's far cortex, whichever comes first: 20-30 mm screws, as in the clinic.
      const Eigen::Vector3d cortex = exitPoint(distance, a, u) - 3.0 * u;
      const Eigen::Vector3d ex = v.info.rotation.col(0);
      const Eigen::Vector3d stop_plane = v.info.body_center + side * 3.0 * ex;
      const Eigen::Vector3d midline = a + ((stop_plane - a).dot(ex) / u.dot(ex)) * u;
      path.target = (midline - a).dot(u) < (cortex - a).dot(u) ? midline : cortex;
      phantom.screw_paths.push_back(path);
    }
  }
}

ImageVolume emptyVolume(const std::array<int, 3>& size, double spacing, const Eigen::Vector3d& origin, PixelType type,
                        const std::string& name) {
  ImageVolume image;
  image.size = size;
  image.spacing = Eigen::Vector3d::Constant(spacing);
  image.origin = origin;
  image.pixel_type = type;
  image.name = name;
  image.frame = "CT";
  image.data.assign(image.byteCount(), std::byte{0});
  return image;
}

}  // namespace

double phantomBoneDistance(const CervicalPhantom& phantom, const Eigen::Vector3d& p_lps) {
  double d = std::numeric_limits<double>::infinity();
  for (const auto& v : phantom.vertebrae) {
    const VertebraShape shape(v.label - kFirstLevelLabel);
    d = std::min(d, shape.distance(v.rotation.transpose() * (p_lps - v.body_center)));
  }
  return d;
}

CervicalPhantom generateCervicalPhantom(const PhantomOptions& options) {
  const double h = options.spacing_mm;
  if (!(h >= 0.2 && h <= 3.0)) {
    throw InvalidArgumentError("phantom spacing " + std::to_string(h) + " mm is outside [0.2, 3] mm");
  }
  if (!(options.noise_sigma_hu >= 0.0) || !std::isfinite(options.noise_sigma_hu)) {
    throw InvalidArgumentError("phantom noise sigma must be a finite value >= 0 HU");
  }
  if ((options.extent_mm.array() < Eigen::Array3d(90.0, 90.0, 110.0)).any()) {
    throw InvalidArgumentError("phantom extent must be at least 90 x 90 x 110 mm to hold C3-C7 and the fiducials");
  }
  CervicalPhantom phantom;
  phantom.seed = options.seed;
  phantom.noise_sigma_hu = options.noise_sigma_hu;
  phantom.vessel_center = Eigen::Vector3d(24.0, -20.0, 0.0);
  const auto vertebrae = placeVertebrae();
  for (const auto& v : vertebrae) {
    phantom.vertebrae.push_back(v.info);
    phantom.label_names[v.info.label] = v.info.name;
  }
  phantom.label_names[kPhantomVesselLabel] = labelInfo(kPhantomVesselLabel, LabelScheme::Verse).name;
  phantom.label_names[kPhantomScrewLabel] = labelInfo(kPhantomScrewLabel, LabelScheme::Verse).name;
  phantom.fiducials_truth.name = "fiducials_truth";
  phantom.fiducials_truth.frame = "CT";
  std::vector<PlacedScrew> screws;
  placeScrews(vertebrae, phantom, screws);
  planPedicleScrews(vertebrae, phantom);

  std::array<int, 3> size{};
  for (int a = 0; a < 3; ++a)
    size[static_cast<std::size_t>(a)] = static_cast<int>(std::lround(options.extent_mm[a] / h));
  const Eigen::Vector3d origin =
      -0.5 * Eigen::Vector3d(size[0] - 1, size[1] - 1, size[2] - 1) * h;  // voxel centres symmetric about 0
  phantom.ct = emptyVolume(size, h, origin, PixelType::Int16, "cervical_phantom_ct");
  phantom.labels = emptyVolume(size, h, origin, PixelType::UInt8, "cervical_phantom_labels");
  phantom.bone_labels = emptyVolume(size, h, origin, PixelType::UInt8, "cervical_phantom_bone_labels");
  std::vector<float> hu(phantom.ct.voxelCount());
  auto* labels = reinterpret_cast<std::uint8_t*>(phantom.labels.data.data());
  auto* bone_labels = reinterpret_cast<std::uint8_t*>(phantom.bone_labels.data.data());
  const double lumen_r = phantom.vessel_lumen_radius_mm;
  const double outer_r = phantom.vessel_outer_radius_mm;
  const Eigen::Vector2d vessel_xy = phantom.vessel_center.head<2>();

  auto fillSlices = [&](int k_begin, int k_end) {
    for (int k = k_begin; k < k_end; ++k) {
      for (int j = 0; j < size[1]; ++j) {
        for (int i = 0; i < size[0]; ++i) {
          const Eigen::Vector3d p = origin + Eigen::Vector3d(i, j, k) * h;
          const std::size_t index = phantom.ct.linearIndex(i, j, k);
          const Eigen::Vector2d q(p.x() / kNeckSemiAxes.x(), p.y() / kNeckSemiAxes.y());
          const double neck = (q.norm() - 1.0) * kNeckSemiAxes.minCoeff();
          double value = D::air + occupancy(neck, h) * (D::soft_tissue - D::air);
          const double trachea = (p.head<2>() - kTracheaCenter.head<2>()).norm() - kTracheaRadiusMm;
          value += occupancy(trachea, h) * (D::air - value);
          const double radial = (p.head<2>() - vessel_xy).norm();
          value += occupancy(radial - outer_r, h) * (D::vessel_wall - value);
          value += occupancy(radial - lumen_r, h) * (D::vessel_lumen - value);
          double bone = std::numeric_limits<double>::infinity();
          int bone_label = 0;
          for (const auto& v : vertebrae) {
            if (v.bounds.exteriorDistance(p) > h) continue;
            const double d = v.distance(p);
            if (d < bone) {
              bone = d;
              bone_label = v.info.label;
            }
          }
          if (bone < h) {
            const double cortex = std::clamp(0.5 + (bone + D::cortex_thickness_mm) / h, 0.0, 1.0);
            const double bone_value = D::cancellous_bone + cortex * (D::cortical_bone - D::cancellous_bone);
            value += occupancy(bone, h) * (bone_value - value);
          }
          double metal = std::numeric_limits<double>::infinity();
          for (const auto& s : screws) {
            if (s.bounds.exteriorDistance(p) > h) continue;
            metal = std::min({metal, cylinder(p, s.tip, s.shoulder, 1.0), cylinder(p, s.shoulder, s.head, 1.75)});
          }
          if (metal < h) value += occupancy(metal, h) * (D::titanium - value);
          hu[index] = static_cast<float>(value);
          std::uint8_t label = 0;
          if (metal < 0.0) {
            label = kPhantomScrewLabel;
          } else if (bone < 0.0) {
            label = static_cast<std::uint8_t>(bone_label);
          } else if (radial < outer_r) {
            label = kPhantomVesselLabel;
          }
          labels[index] = label;
          bone_labels[index] = bone < 0.0 ? static_cast<std::uint8_t>(bone_label) : std::uint8_t{0};
        }
      }
    }
  };
  parallelForBlocks(
      0, static_cast<std::size_t>(size[2]),
      [&](std::size_t k_begin, std::size_t k_end) { fillSlices(static_cast<int>(k_begin), static_cast<int>(k_end)); },
      std::min(defaultThreadCount(), 4U));

  // Noise drawn in one sequential pass (Box-Muller over mt19937_64, whose
  // sequence the standard fixes) so a seed gives the same volume everywhere.
  std::mt19937_64 engine(options.seed);
  const double to_unit = 1.0 / 18446744073709551616.0;  // 2^-64
  auto* out = reinterpret_cast<std::int16_t*>(phantom.ct.data.data());
  for (std::size_t i = 0; i < hu.size(); i += 2) {
    const double u1 = (static_cast<double>(engine()) + 0.5) * to_unit;
    const double u2 = (static_cast<double>(engine()) + 0.5) * to_unit;
    const double r = options.noise_sigma_hu * std::sqrt(-2.0 * std::log(u1));
    const double n0 = r * std::cos(2.0 * std::numbers::pi * u2);
    const double n1 = r * std::sin(2.0 * std::numbers::pi * u2);
    out[i] = static_cast<std::int16_t>(std::clamp(std::lround(hu[i] + n0), -1024L, 3071L));
    if (i + 1 < hu.size())
      out[i + 1] = static_cast<std::int16_t>(std::clamp(std::lround(hu[i + 1] + n1), -1024L, 3071L));
  }
  return phantom;
}

}  // namespace mrsns::registration
