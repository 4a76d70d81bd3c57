#pragma once
// Names and display colours of label-map values: VerSe vertebra labels,
// TotalSegmentator v2 ("total" task) classes and the MR-SNS cervical phantom.
#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

namespace mrsns::registration {

enum class LabelScheme {
  Auto,              ///< chosen from the labels present (see detectLabelScheme)
  Verse,             ///< 1-7 C1-C7, 8-19 T1-T12, 20-25 L1-L6, 28 T13; plus the phantom's 91/92
  TotalSegmentator,  ///< TotalSegmentator v2 "total" task, 1-117 (26 vertebrae_S1 ... 50 vertebrae_C1)
  Generic,           ///< "label_<n>"
};

/// Labels of the MR-SNS cervical phantom besides its VerSe vertebra labels (C3..C7 = 3..7).
inline constexpr int kPhantomVesselLabel = 91;
inline constexpr int kPhantomScrewLabel = 92;

struct LabelInfo {
  std::string name;
  Eigen::Vector3d color = Eigen::Vector3d(0.8, 0.8, 0.8);  ///< RGB in [0, 1]
  bool vertebra = false;
};

/// "verse", "totalsegmentator", "generic", "auto".
[[nodiscard]] std::string labelSchemeName(LabelScheme scheme);
/// Inverse of labelSchemeName; throws InvalidArgumentError naming the accepted values.
[[nodiscard]] LabelScheme labelSchemeFromName(const std::string& name);

/// TotalSegmentator when any label lies outside VerSe's 1-28 and the
/// phantom's 91/92, else VerSe. (Both number vertebrae with small integers,
/// so a map holding only labels 26-28 is ambiguous: pass the scheme then.)
[[nodiscard]] LabelScheme detectLabelScheme(const std::vector<int>& labels);

/// Name and colour of `label` in `scheme` (Auto is treated as Generic).
/// Vertebrae get VerSe/TotalSegmentator names ("C5" / "vertebrae_C5") and a
/// colour that cycles along the spine so that neighbours differ.
[[nodiscard]] LabelInfo labelInfo(int label, LabelScheme scheme);

/// The TotalSegmentator v2 label of a class name ("vertebrae_L1" -> 31), if known.
[[nodiscard]] std::optional<int> totalSegmentatorLabel(const std::string& name);

/// The VerSe label of a vertebra name ("C3" -> 3, "T13" -> 28, "L6" -> 25), if known.
[[nodiscard]] std::optional<int> verseLabel(const std::string& vertebra);

}  // namespace mrsns::registration
