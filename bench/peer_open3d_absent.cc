// Built when CMake does not find Open3D (no Open3D rows in the benchmarks), and linked into the
// peer programs of the other libraries.
#include "bench/peers.h"

namespace meshsmooth::bench {
std::vector<Peer> Open3dPeers() { return {}; }
}  // namespace meshsmooth::bench
