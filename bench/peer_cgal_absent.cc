// Built when CMake does not find CGAL: no CGAL rows in the benchmark.
#include "bench/peers.h"

namespace meshsmooth::bench {
std::vector<Peer> CgalPeers() { return {}; }
}  // namespace meshsmooth::bench
