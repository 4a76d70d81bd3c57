#pragma once
// The WebXR page is served over HTTPS because headset browsers only offer
// WebXR (and the microphone) to a secure context. A lab has no certificate
// authority for a workstation on its own network, so the workstation makes a
// self-signed certificate on first use and keeps it, so a headset that
// accepted it once is not asked again. Its fingerprint is shown beside the
// pairing code, for the operator to compare with what the headset's browser
// shows.
#include <filesystem>
#include <string>
#include <vector>

namespace mrsns::webxr {

struct TlsCertificate {
  std::filesystem::path certificate_pem;
  std::filesystem::path private_key_pem;
  std::string sha256_fingerprint;  ///< "AB:CD:..." of the DER certificate
  bool generated = false;          ///< made by this call (first use)
};

/// The certificate in `directory` (certificate.pem, private-key.pem), made
/// there first when either is missing: an ECDSA P-256 key (file mode 0600),
/// a self-signed X.509 v3 certificate valid for 825 days whose subject
/// alternative names are `hosts` (IP addresses or DNS names; localhost and
/// 127.0.0.1 always). An existing pair is used as it is. Throws FileError
/// when the directory cannot be written or a file cannot be read, FormatError
/// when an existing file is not a PEM certificate or key.
TlsCertificate ensureSelfSignedCertificate(const std::filesystem::path& directory,
                                           const std::vector<std::string>& hosts);

/// The default folder: $XDG_CONFIG_HOME/mrsns/webxr-tls, else ~/.config/mrsns/webxr-tls.
std::filesystem::path defaultCertificateDirectory();

}  // namespace mrsns::webxr
