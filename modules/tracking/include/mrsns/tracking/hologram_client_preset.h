#pragma once
// What each OpenIGTLink headset client labs use reads from the hologram
// stream, chosen by name (`mrsns-cli serve --client NAME`, the GUI's
// Holograms panel). The clients disagree: one reads header v1 TRANSFORMs
// only and converts millimetres and handedness itself, another needs header
// v2 and moves one object with every TRANSFORM, Slicer takes everything in
// millimetres as it is. A stream set up for one shows a mirrored or scaled
// pose in another, so the preset names the client, not the options.
//
// Each preset is checked by a test that decodes the stream as that client's
// own code does (tests/tracking/test_hologram_client_presets.cpp); the
// client's source and what it does with each message are in
// modules/tracking/doc/hmd_clients.md.
#include <string>
#include <string_view>
#include <vector>

#include "mrsns/tracking/hologram_streamer.h"

namespace mrsns::tracking {

struct HologramClientPreset {
  std::string name;         ///< e.g. "openigtlink-unity"
  std::string description;  ///< the client it matches, in one line
  igtlink::HeaderVersion version = igtlink::HeaderVersion::kV2;
  bool unity = false;            ///< HologramStreamOptions::unity (our conversion on the wire)
  bool transforms_only = false;  ///< HologramStreamOptions::transforms_only
  std::size_t max_streams = 0;   ///< HologramStreamOptions::max_streams
};

/// Every preset, the default ("slicer") first.
const std::vector<HologramClientPreset>& hologramClientPresets();

/// The preset of that name. Throws InvalidArgumentError naming the known ones.
const HologramClientPreset& hologramClientPreset(std::string_view name);

/// `options` with the preset's header version, convention and message set; a
/// client limited in streams (max_streams) gets no forward_transforms.
HologramStreamOptions withClientPreset(HologramStreamOptions options, const HologramClientPreset& preset);

}  // namespace mrsns::tracking
