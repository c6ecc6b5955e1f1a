// Built when CMake does not find CGAL (no CGAL rows in the benchmarks), and linked into the peer
// programs of the other libraries.
#include "bench/peers.h"

namespace meshsmooth::bench {
std::vector<Peer> CgalPeers(double) { return {}; }
}  // namespace meshsmooth::bench
