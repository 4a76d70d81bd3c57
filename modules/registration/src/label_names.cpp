// Label tables. TotalSegmentator v2 class map of the "total" task
// (totalsegmentator/map_to_binary.py, class_map["total"]); VerSe labels as in
// the VerSe challenge data description (Sekuboyina et al. 2021).
#include "mrsns/registration/label_names.h"

#include <array>

#include "mrsns/core/error.h"

namespace mrsns::registration {
namespace {

constexpr std::array<const char*, 118> kTotalSegmentator = {"background",
                                                            "spleen",
                                                            "kidney_right",
                                                            "kidney_left",
                                                            "gallbladder",
                                                            "liver",
                                                            "stomach",
                                                            "pancreas",
                                                            "adrenal_gland_right",
                                                            "adrenal_gland_left",
                                                            "lung_upper_lobe_left",
                                                            "lung_lower_lobe_left",
                                                            "lung_upper_lobe_right",
                                                            "lung_middle_lobe_right",
                                                            "lung_lower_lobe_right",
                                                            "esophagus",
                                                            "trachea",
                                                            "thyroid_gland",
                                                            "small_bowel",
                                                            "duodenum",
                                                            "colon",
                                                            "urinary_bladder",
                                                            "prostate",
                                                            "kidney_cyst_left",
                                                            "kidney_cyst_right",
                                                            "sacrum",
                                                            "vertebrae_S1",
                                                            "vertebrae_L5",
                                                            "vertebrae_L4",
                                                            "vertebrae_L3",
                                                            "vertebrae_L2",
                                                            "vertebrae_L1",
                                                            "vertebrae_T12",
                                                            "vertebrae_T11",
                                                            "vertebrae_T10",
                                                            "vertebrae_T9",
                                                            "vertebrae_T8",
                                                            "vertebrae_T7",
                                                            "vertebrae_T6",
                                                            "vertebrae_T5",
                                                            "vertebrae_T4",
                                                            "vertebrae_T3",
                                                            "vertebrae_T2",
                                                            "vertebrae_T1",
                                                            "vertebrae_C7",
                                                            "vertebrae_C6",
                                                            "vertebrae_C5",
                                                            "vertebrae_C4",
                                                            "vertebrae_C3",
                                                            "vertebrae_C2",
                                                            "vertebrae_C1",
                                                            "heart",
                                                            "aorta",
                                                            "pulmonary_vein",
                                                            "brachiocephalic_trunk",
                                                            "subclavian_artery_right",
                                                            "subclavian_artery_left",
                                                            "common_carotid_artery_right",
                                                            "common_carotid_artery_left",
                                                            "brachiocephalic_vein_left",
                                                            "brachiocephalic_vein_right",
                                                            "atrial_appendage_left",
                                                            "superior_vena_cava",
                                                            "inferior_vena_cava",
                                                            "portal_vein_and_splenic_vein",
                                                            "iliac_artery_left",
                                                            "iliac_artery_right",
                                                            "iliac_vena_left",
                                                            "iliac_vena_right",
                                                            "humerus_left",
                                                            "humerus_right",
                                                            "scapula_left",
                                                            "scapula_right",
                                                            "clavicula_left",
                                                            "clavicula_right",
                                                            "femur_left",
                                                            "femur_right",
                                                            "hip_left",
                                                            "hip_right",
                                                            "spinal_cord",
                                                            "gluteus_maximus_left",
                                                            "gluteus_maximus_right",
                                                            "gluteus_medius_left",
                                                            "gluteus_medius_right",
                                                            "gluteus_minimus_left",
                                                            "gluteus_minimus_right",
                                                            "autochthon_left",
                                                            "autochthon_right",
                                                            "iliopsoas_left",
                                                            "iliopsoas_right",
                                                            "brain",
                                                            "skull",
                                                            "rib_left_1",
                                                            "rib_left_2",
                                                            "rib_left_3",
                                                            "rib_left_4",
                                                            "rib_left_5",
                                                            "rib_left_6",
                                                            "rib_left_7",
                                                            "rib_left_8",
                                                            "rib_left_9",
                                                            "rib_left_10",
                                                            "rib_left_11",
                                                            "rib_left_12",
                                                            "rib_right_1",
                                                            "rib_right_2",
                                                            "rib_right_3",
                                                            "rib_right_4",
                                                            "rib_right_5",
                                                            "rib_right_6",
                                                            "rib_right_7",
                                                            "rib_right_8",
                                                            "rib_right_9",
                                                            "rib_right_10",
                                                            "rib_right_11",
                                                            "rib_right_12",
                                                            "sternum",
                                                            "costal_cartilages"};

/// VerSe name of a vertebra label, empty if the label is not a vertebra.
std::string verseName(int label) {
  // Built with append: GCC 12 warns (-Wrestrict, falsely) on "C" + std::to_string(n).
  auto named = [](char region, int number) {
    std::string name(1, region);
    name.append(std::to_string(number));
    return name;
  };
  if (label >= 1 && label <= 7) return named('C', label);
  if (label >= 8 && label <= 19) return named('T', label - 7);
  if (label >= 20 && label <= 25) return named('L', label - 19);
  if (label == 26) return "sacrum";  // VerSe's optional sacrum label
  if (label == 28) return "T13";
  return {};
}

/// Spine position from the top (C1 = 0) used for colours: neighbours differ.
Eigen::Vector3d vertebraColor(int position) {
  static const std::array<Eigen::Vector3d, 6> palette = {
      Eigen::Vector3d(0.89, 0.85, 0.72), Eigen::Vector3d(0.95, 0.70, 0.55), Eigen::Vector3d(0.70, 0.82, 0.92),
      Eigen::Vector3d(0.78, 0.90, 0.64), Eigen::Vector3d(0.96, 0.80, 0.90), Eigen::Vector3d(0.85, 0.75, 0.95)};
  return palette[static_cast<std::size_t>(((position % 6) + 6) % 6)];
}

}  // namespace

std::string labelSchemeName(LabelScheme scheme) {
  switch (scheme) {
    case LabelScheme::Auto: return "auto";
    case LabelScheme::Verse: return "verse";
    case LabelScheme::TotalSegmentator: return "totalsegmentator";
    case LabelScheme::Generic: return "generic";
  }
  return "generic";
}

LabelScheme labelSchemeFromName(const std::string& name) {
  for (auto s : {LabelScheme::Auto, LabelScheme::Verse, LabelScheme::TotalSegmentator, LabelScheme::Generic}) {
    if (labelSchemeName(s) == name) return s;
  }
  throw InvalidArgumentError("unknown label scheme '" + name + "': use auto, verse, totalsegmentator or generic");
}

LabelScheme detectLabelScheme(const std::vector<int>& labels) {
  for (int l : labels) {
    if (l == 0 || l == kPhantomVesselLabel || l == kPhantomScrewLabel) continue;
    if (l < 1 || l > 28) return LabelScheme::TotalSegmentator;
  }
  return LabelScheme::Verse;
}

LabelInfo labelInfo(int label, LabelScheme scheme) {
  LabelInfo info;
  info.name = "label_";
  info.name.append(std::to_string(label));
  if (scheme == LabelScheme::Verse) {
    const std::string name = verseName(label);
    if (!name.empty()) {
      info.name = name;
      info.vertebra = true;
      info.color = vertebraColor(label == 28 ? 20 : label - 1);
    } else if (label == kPhantomVesselLabel) {
      info.name = "carotid_artery";
      info.color = Eigen::Vector3d(0.85, 0.15, 0.15);
    } else if (label == kPhantomScrewLabel) {
      info.name = "fiducial_screws";
      info.color = Eigen::Vector3d(0.55, 0.60, 0.68);
    }
  } else if (scheme == LabelScheme::TotalSegmentator) {
    if (label >= 1 && label < static_cast<int>(kTotalSegmentator.size())) {
      info.name = kTotalSegmentator[static_cast<std::size_t>(label)];
      if (label >= 26 && label <= 50) {
        info.vertebra = true;
        info.color = vertebraColor(50 - label);
      } else if (info.name.find("arter") != std::string::npos || info.name == "aorta" ||
                 info.name == "brachiocephalic_trunk") {
        info.color = Eigen::Vector3d(0.85, 0.15, 0.15);
      } else if (info.name.find("vein") != std::string::npos || info.name.find("vena") != std::string::npos) {
        info.color = Eigen::Vector3d(0.2, 0.35, 0.85);
      }
    }
  }
  return info;
}

std::optional<int> totalSegmentatorLabel(const std::string& name) {
  for (std::size_t i = 1; i < kTotalSegmentator.size(); ++i) {
    if (name == kTotalSegmentator[i]) return static_cast<int>(i);
  }
  return std::nullopt;
}

std::optional<int> verseLabel(const std::string& vertebra) {
  for (int l = 1; l <= 28; ++l) {
    if (verseName(l) == vertebra) return l;
  }
  return std::nullopt;
}

}  // namespace mrsns::registration
