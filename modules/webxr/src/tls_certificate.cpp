#include "mrsns/webxr/tls_certificate.h"

#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/x509.h>
#include <openssl/x509v3.h>
#include <sys/stat.h>

#include <array>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <set>

#include "mrsns/core/error.h"

namespace mrsns::webxr {
namespace fs = std::filesystem;
namespace {

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;
using Key = std::unique_ptr<EVP_PKEY, decltype(&EVP_PKEY_free)>;
using Certificate = std::unique_ptr<X509, decltype(&X509_free)>;

File openFile(const fs::path& path, const char* mode) {
  File f(std::fopen(path.c_str(), mode));
  if (!f) throw FileError("cannot open " + path.string() + (mode[0] == 'r' ? " for reading" : " for writing"));
  return f;
}

std::string fingerprint(X509* certificate) {
  std::array<unsigned char, EVP_MAX_MD_SIZE> digest{};
  unsigned int n = 0;
  X509_digest(certificate, EVP_sha256(), digest.data(), &n);
  std::string text;
  static constexpr char kHex[] = "0123456789ABCDEF";
  for (unsigned int i = 0; i < n; ++i) {
    if (i > 0) text += ':';
    text += kHex[digest[i] >> 4];
    text += kHex[digest[i] & 0xF];
  }
  return text;
}

bool isIpAddress(const std::string& host) {
  return host.find_first_not_of("0123456789.") == std::string::npos || host.find(':') != std::string::npos;
}

void generate(const fs::path& certificate_path, const fs::path& key_path, const std::vector<std::string>& hosts) {
  Key key(EVP_EC_gen("P-256"), EVP_PKEY_free);
  if (!key) throw ComputationError("OpenSSL could not generate an EC P-256 key");
  Certificate certificate(X509_new(), X509_free);
  X509_set_version(certificate.get(), 2);
  {
    std::unique_ptr<BIGNUM, decltype(&BN_free)> serial(BN_new(), BN_free);
    BN_rand(serial.get(), 127, BN_RAND_TOP_ANY, BN_RAND_BOTTOM_ANY);
    BN_to_ASN1_INTEGER(serial.get(), X509_get_serialNumber(certificate.get()));
  }
  X509_gmtime_adj(X509_getm_notBefore(certificate.get()), -60L * 60);
  X509_gmtime_adj(X509_getm_notAfter(certificate.get()), 825L * 24 * 60 * 60);
  X509_set_pubkey(certificate.get(), key.get());
  X509_NAME* name = X509_get_subject_name(certificate.get());
  X509_NAME_add_entry_by_txt(name, "O", MBSTRING_ASC, reinterpret_cast<const unsigned char*>("MR-SNS workstation"), -1,
                             -1, 0);
  X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_ASC, reinterpret_cast<const unsigned char*>("MR-SNS WebXR client"),
                             -1, -1, 0);
  X509_set_issuer_name(certificate.get(), name);

  std::set<std::string> names{"localhost", "127.0.0.1"};
  names.insert(hosts.begin(), hosts.end());
  std::string san;
  for (const auto& host : names) {
    if (host.empty() || host == "0.0.0.0" || host == "::") continue;
    if (!san.empty()) san += ',';
    san += (isIpAddress(host) ? "IP:" : "DNS:") + host;
  }
  X509V3_CTX context;
  X509V3_set_ctx_nodb(&context);
  X509V3_set_ctx(&context, certificate.get(), certificate.get(), nullptr, nullptr, 0);
  for (const auto& [nid, value] :
       {std::pair{NID_subject_alt_name, san}, std::pair{NID_basic_constraints, std::string("critical,CA:FALSE")},
        std::pair{NID_ext_key_usage, std::string("serverAuth")},
        std::pair{NID_key_usage, std::string("critical,digitalSignature")}}) {
    X509_EXTENSION* extension = X509V3_EXT_conf_nid(nullptr, &context, nid, value.c_str());
    if (extension == nullptr) throw InvalidArgumentError("cannot put '" + value + "' in the certificate");
    X509_add_ext(certificate.get(), extension, -1);
    X509_EXTENSION_free(extension);
  }
  if (X509_sign(certificate.get(), key.get(), EVP_sha256()) == 0)
    throw ComputationError("OpenSSL could not sign the certificate");

  {
    // The key is readable by its owner alone, from its creation on.
    const mode_t old_mask = ::umask(077);
    File key_file = openFile(key_path, "wb");
    ::umask(old_mask);
    if (PEM_write_PrivateKey(key_file.get(), key.get(), nullptr, nullptr, 0, nullptr, nullptr) == 0) {
      throw FileError("cannot write " + key_path.string());
    }
  }
  File certificate_file = openFile(certificate_path, "wb");
  if (PEM_write_X509(certificate_file.get(), certificate.get()) == 0) {
    throw FileError("cannot write " + certificate_path.string());
  }
}

}  // namespace

fs::path defaultCertificateDirectory() {
  if (const char* xdg = std::getenv("XDG_CONFIG_HOME"); xdg != nullptr && *xdg != '\0') {
    return fs::path(xdg) / "mrsns" / "webxr-tls";
  }
  const char* home = std::getenv("HOME");
  return fs::path(home != nullptr ? home : ".") / ".config" / "mrsns" / "webxr-tls";
}

TlsCertificate ensureSelfSignedCertificate(const fs::path& directory, const std::vector<std::string>& hosts) {
  TlsCertificate result{directory / "certificate.pem", directory / "private-key.pem", {}, false};
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (ec) throw FileError("cannot create " + directory.string() + ": " + ec.message());
  if (!fs::exists(result.certificate_pem) || !fs::exists(result.private_key_pem)) {
    generate(result.certificate_pem, result.private_key_pem, hosts);
    result.generated = true;
  }
  File certificate_file = openFile(result.certificate_pem, "rb");
  Certificate certificate(PEM_read_X509(certificate_file.get(), nullptr, nullptr, nullptr), X509_free);
  if (!certificate)
    throw FormatError(result.certificate_pem.string() + " is not a PEM certificate (delete it to make a new one)");
  File key_file = openFile(result.private_key_pem, "rb");
  Key key(PEM_read_PrivateKey(key_file.get(), nullptr, nullptr, nullptr), EVP_PKEY_free);
  if (!key)
    throw FormatError(result.private_key_pem.string() + " is not a PEM private key (delete it to make a new one)");
  if (X509_check_private_key(certificate.get(), key.get()) != 1) {
    throw FormatError(result.certificate_pem.string() + " and " + result.private_key_pem.string() +
                      " do not belong together (delete both to make a new pair)");
  }
  result.sha256_fingerprint = fingerprint(certificate.get());
  return result;
}

}  // namespace mrsns::webxr
