// Linked into the peer programs of the other libraries (meshsmooth_peer_open3d, _cgal), so that
// their processes load no OpenMesh.
#include "bench/peers.h"

namespace meshsmooth::bench {
std::vector<Peer> OpenMeshPeers() { return {}; }
}  // namespace meshsmooth::bench
