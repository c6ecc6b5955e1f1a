#include "bench/peers.h"

namespace meshsmooth::bench {

std::vector<Peer> AllPeers(double smooth_shape_time) {
  std::vector<Peer> peers;
  for (auto&& list : {OpenMeshPeers(), Open3dPeers(), CgalPeers(smooth_shape_time)}) {
    peers.insert(peers.end(), list.begin(), list.end());
  }
  return peers;
}

const Peer* FindPeer(const std::vector<Peer>& peers, std::string_view id) {
  for (const Peer& p : peers) {
    if (p.id == id) return &p;
  }
  return nullptr;
}

}  // namespace meshsmooth::bench
