#include "mrsns/tracking/hologram_client_preset.h"

#include "mrsns/core/error.h"

namespace mrsns::tracking {

const std::vector<HologramClientPreset>& hologramClientPresets() {
  static const std::vector<HologramClientPreset> presets = [] {
    std::vector<HologramClientPreset> p;
    // openigtlink/SlicerOpenIGTLink: any header version, CRC checked, a TRANSFORM becomes the linear transform node
    // of its device name as it is (mm, RAS), POLYDATA a model node, STATUS a status node, STRING a text node.
    p.push_back({"slicer",
                 "3D Slicer's OpenIGTLinkIF connected as a client (a viewer): header v2 with metadata, models as "
                 "POLYDATA, millimetres as they are, tracking changes as STATUS, prompts as STRING",
                 igtlink::HeaderVersion::kV2, false, false, 0});
    // franklinwk/OpenIGTLink-Unity (OpenIGTLinkConnect.cs): reads only whole v1 TRANSFORMs (a read that is not a
    // multiple of 106 bytes is dropped, any other type ends the read), divides the translation by 1000 and mirrors
    // x itself, and moves the scene's GameObjects of the device's name.
    p.push_back({"openigtlink-unity",
                 "OpenIGTLink-Unity (franklinwk/OpenIGTLink-Unity and its forks): header v1 TRANSFORMs only, in "
                 "millimetres, right-handed (the client mirrors x and scales itself); the models are GameObjects of "
                 "the models' names in its Unity scene",
                 igtlink::HeaderVersion::kV1, false, true, 0});
    // BSEL-UC3M/HoloLens2and3DSlicer-PedicleScrewPlacementPlanning (ReadMessageFromServer.cs): reads the matrix
    // 12 bytes after the header (the v2 extended header), converts like OpenIGTLink-Unity, and moves its one
    // MovingPlane with every TRANSFORM whatever its name; its models are prefabs loaded by name.
    p.push_back({"hololens2-pedicle",
                 "the HoloLens 2 + 3D Slicer pedicle-screw planning app (BSEL-UC3M): header v2 TRANSFORMs only, in "
                 "millimetres, right-handed (the client mirrors x and scales itself); it moves one object with every "
                 "TRANSFORM, so one model is streamed",
                 igtlink::HeaderVersion::kV2, false, true, 1});
    // Our own convention for a Unity app that applies what it receives as it is.
    p.push_back({"unity-metres",
                 "a Unity app that applies poses as received: left-handed metres on the wire (x mirrored, mm to m) "
                 "for meshes and transforms alike, header v2 with metadata",
                 igtlink::HeaderVersion::kV2, true, false, 0});
    return p;
  }();
  return presets;
}

const HologramClientPreset& hologramClientPreset(std::string_view name) {
  std::string known;
  for (const auto& preset : hologramClientPresets()) {
    if (preset.name == name) return preset;
    known += (known.empty() ? "" : ", ") + preset.name;
  }
  throw InvalidArgumentError("unknown headset client '" + std::string(name) + "'; known clients: " + known);
}

HologramStreamOptions withClientPreset(HologramStreamOptions options, const HologramClientPreset& preset) {
  options.version = preset.version;
  options.unity = preset.unity;
  options.transforms_only = preset.transforms_only;
  options.max_streams = preset.max_streams;
  // A client that moves one object with every TRANSFORM would move it with the tools too.
  if (preset.max_streams > 0) options.forward_transforms.clear();
  return options;
}

}  // namespace mrsns::tracking
