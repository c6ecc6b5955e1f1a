// Built when CMake does not find CGAL: no CGAL rows in the benchmarks.
#include "bench/peers.h"

namespace meshsmooth::bench {
std::vector<Peer> CgalPeers(double) { return {}; }
}  // namespace meshsmooth::bench
