// Where bundled resources are: the source tree for builds, share/mrsns for installs.
#include <unistd.h>

#include <cstdlib>
#include <system_error>

#include "mrsns/core/error.h"
#include "mrsns/workflow/steps.h"

namespace mrsns::workflow {

namespace fs = std::filesystem;

namespace {

fs::path executableDirectory() {
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  return ec ? fs::path() : exe.parent_path();
}

}  // namespace

fs::path resourceDirectory() {
  // Installed layout first: a program under <prefix>/bin must not pick up a
  // source tree that happens to exist on the build machine.
  const fs::path exe_dir = executableDirectory();
  std::error_code ec;
  if (!exe_dir.empty()) {
    const fs::path installed = exe_dir.parent_path() / "share" / "mrsns";
    if (fs::is_directory(installed, ec)) return installed;
  }
#ifdef MRSNS_SOURCE_RESOURCES
  if (fs::is_directory(MRSNS_SOURCE_RESOURCES, ec)) return MRSNS_SOURCE_RESOURCES;
#endif
  throw FileError("MR-SNS resources not found (looked in '" + (exe_dir.parent_path() / "share/mrsns").string() +
                  "' and the source tree): reinstall the package");
}

fs::path sampleSessionPath() {
  std::error_code ec;
  if (const char* env = std::getenv("MRSNS_SAMPLE_SESSION"); env != nullptr && *env != '\0') {
    if (fs::is_regular_file(fs::path(env) / "session.json", ec)) return env;
    throw FileError(std::string("MRSNS_SAMPLE_SESSION='") + env +
                    "' holds no session.json: unset it or point it at a session folder");
  }
  const fs::path sample = resourceDirectory() / "sample_session";
  if (!fs::is_regular_file(sample / "session.json", ec)) {
    throw FileError("the bundled sample session is missing ('" + (sample / "session.json").string() +
                    "'): reinstall the package");
  }
  return sample;
}

Session createSessionFromSample(const fs::path& folder) {
  const fs::path sample = sampleSessionPath();
  Session session = Session::create(folder);
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(sample, ec)) {
    if (entry.path().filename() == "README.md") continue;
    fs::copy(entry.path(), session.folder() / entry.path().filename(),
             fs::copy_options::recursive | fs::copy_options::overwrite_existing, ec);
    if (ec) {
      throw FileError("copying the sample session into '" + folder.string() + "' failed: " + ec.message());
    }
  }
  return Session::open(folder);
}

}  // namespace mrsns::workflow
