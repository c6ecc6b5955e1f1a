// Built when CMake does not find Open3D: no Open3D rows in the benchmarks.
#include "bench/peers.h"

namespace meshsmooth::bench {
std::vector<Peer> Open3dPeers() { return {}; }
}  // namespace meshsmooth::bench
