// The WebXR server's certificate: made once with the right names and a
// private key only its owner reads, then reused; a damaged file is named.
#include <gtest/gtest.h>
#include <openssl/pem.h>
#include <openssl/x509v3.h>
#include <sys/stat.h>

#include <cstdio>
#include <memory>

#include "mrsns/core/error.h"
#include "mrsns/webxr/tls_certificate.h"
#include "test_data.h"

namespace mrsns::webxr {
namespace {

std::vector<std::string> subjectAltNames(const std::filesystem::path& pem) {
  std::unique_ptr<FILE, decltype(&std::fclose)> f(std::fopen(pem.c_str(), "rb"), &std::fclose);
  std::unique_ptr<X509, decltype(&X509_free)> cert(PEM_read_X509(f.get(), nullptr, nullptr, nullptr), X509_free);
  std::vector<std::string> names;
  auto* sans = static_cast<GENERAL_NAMES*>(X509_get_ext_d2i(cert.get(), NID_subject_alt_name, nullptr, nullptr));
  for (int i = 0; sans != nullptr && i < sk_GENERAL_NAME_num(sans); ++i) {
    const GENERAL_NAME* name = sk_GENERAL_NAME_value(sans, i);
    if (name->type == GEN_DNS) {
      names.emplace_back(reinterpret_cast<const char*>(ASN1_STRING_get0_data(name->d.dNSName)));
    } else if (name->type == GEN_IPADD && ASN1_STRING_length(name->d.iPAddress) == 4) {
      const unsigned char* ip = ASN1_STRING_get0_data(name->d.iPAddress);
      names.push_back(std::to_string(ip[0]) + "." + std::to_string(ip[1]) + "." + std::to_string(ip[2]) + "." +
                      std::to_string(ip[3]));
    }
  }
  GENERAL_NAMES_free(sans);
  return names;
}

TEST(TlsCertificate, MadeOnFirstUseWithTheHostsThenReused) {
  const auto dir = test::scratchDirectory("tls");
  const auto first = ensureSelfSignedCertificate(dir, {"192.168.10.5", "navigation-ws.local"});
  EXPECT_TRUE(first.generated);
  EXPECT_EQ(first.sha256_fingerprint.size(), 32U * 3 - 1);
  const auto names = subjectAltNames(first.certificate_pem);
  for (const char* expected : {"localhost", "127.0.0.1", "192.168.10.5", "navigation-ws.local"}) {
    EXPECT_NE(std::find(names.begin(), names.end(), expected), names.end()) << expected;
  }
  struct stat key_stat {};
  ASSERT_EQ(::stat(first.private_key_pem.c_str(), &key_stat), 0);
  EXPECT_EQ(key_stat.st_mode & 0077, 0U) << "the private key is readable by others";

  const auto again = ensureSelfSignedCertificate(dir, {});
  EXPECT_FALSE(again.generated);
  EXPECT_EQ(again.sha256_fingerprint, first.sha256_fingerprint) << "a headset that accepted it must not be asked again";
}

TEST(TlsCertificate, DamagedFilesAreNamed) {
  const auto dir = test::scratchDirectory("tls");
  const auto made = ensureSelfSignedCertificate(dir, {});
  test::writeBytes(made.certificate_pem, "-----BEGIN CERTIFICATE-----\nnot base64\n");
  try {
    (void)ensureSelfSignedCertificate(dir, {});
    FAIL() << "a damaged certificate was accepted";
  } catch (const FormatError& e) {
    EXPECT_NE(std::string(e.what()).find("certificate.pem"), std::string::npos) << e.what();
  }
  // Another pair's key does not fit the certificate.
  const auto other = ensureSelfSignedCertificate(test::scratchDirectory("other"), {});
  std::filesystem::remove(made.certificate_pem);
  std::filesystem::remove(made.private_key_pem);
  (void)ensureSelfSignedCertificate(dir, {});
  std::filesystem::copy_file(other.private_key_pem, made.private_key_pem,
                             std::filesystem::copy_options::overwrite_existing);
  EXPECT_THROW((void)ensureSelfSignedCertificate(dir, {}), FormatError);
}

}  // namespace
}  // namespace mrsns::webxr
