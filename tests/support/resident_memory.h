#pragma once
// Resident memory of the test process, for the load tests' memory bounds
// (the server, the good client and the attackers live in one process; the
// attackers reuse small buffers, so growth is the server's).
#include <unistd.h>

#include <fstream>

namespace mrsns::test {

inline double residentMegabytes() {
  std::ifstream statm("/proc/self/statm");
  long pages_total = 0, pages_resident = 0;
  statm >> pages_total >> pages_resident;
  return static_cast<double>(pages_resident) * static_cast<double>(::sysconf(_SC_PAGESIZE)) / 1e6;
}

}  // namespace mrsns::test
