#include "bench/service_floor.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <numeric>
#include <string>
#include <thread>
#include <vector>

#include "core/io/draco_codec.h"

namespace meshsmooth::bench {
namespace {

// Raw TCP on loopback: `bytes` from a client socket to a thread that sends as many back (an
// upload and a download without gRPC, HTTP/2 or protobuf); ms, median of `runs`, -1 on failure.
double LoopbackTcpMs(size_t bytes, int runs) {
  const int listener = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t len = sizeof addr;
  if (listener < 0 || bind(listener, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0 ||
      listen(listener, 1) != 0 || getsockname(listener, reinterpret_cast<sockaddr*>(&addr), &len) != 0) {
    if (listener >= 0) close(listener);
    return -1.0;
  }
  auto send_all = [](int fd, const char* p, size_t n) {
    for (ssize_t k = 0; n > 0; p += k, n -= static_cast<size_t>(k)) {
      if ((k = send(fd, p, n, MSG_NOSIGNAL)) <= 0) return false;
    }
    return true;
  };
  auto recv_all = [](int fd, char* p, size_t n) {
    for (ssize_t k = 0; n > 0; p += k, n -= static_cast<size_t>(k)) {
      if ((k = recv(fd, p, n, 0)) <= 0) return false;
    }
    return true;
  };
  std::thread echo([&] {
    const int fd = accept(listener, nullptr, nullptr);
    if (fd < 0) return;
    std::string buf(bytes, '\0');
    for (int r = 0; r < runs && recv_all(fd, buf.data(), bytes) && send_all(fd, buf.data(), bytes); ++r) {
    }
    close(fd);
  });
  std::vector<double> t;
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd >= 0 && connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) == 0) {
    std::string up(bytes, 'u'), down(bytes, '\0');
    for (int r = 0; r < runs; ++r) {
      const auto t0 = Clock::now();
      if (!send_all(fd, up.data(), bytes) || !recv_all(fd, down.data(), bytes)) break;
      t.push_back(Ms(t0, Clock::now()));
    }
  }
  if (fd >= 0) close(fd);
  shutdown(listener, SHUT_RDWR);  // wakes the echo thread if no connection came
  echo.join();
  close(listener);
  return t.size() == static_cast<size_t>(runs) ? Median(t) : -1.0;
}

// The least neighbour structure a one-ring smoother needs: every vertex's unique neighbours
// (CSR) from the triangles, by a counting sort of the corners, then a sort and unique per
// vertex on all threads. No fans, kinds or counts. ms, median of `runs`.
double UniqueNeighboursMs(const Mesh& mesh, int runs) {
  const int32_t n = mesh.num_vertices();
  std::vector<double> t;
  int64_t kept = 0;
  for (int r = 0; r < runs; ++r) {
    const auto t0 = Clock::now();
    std::vector<int32_t> offsets(static_cast<size_t>(n) + 1, 0);
    for (const Triangle& tri : mesh.triangles) {
      for (int32_t v : tri) offsets[v + 1] += 2;
    }
    std::partial_sum(offsets.begin(), offsets.end(), offsets.begin());
    std::vector<int32_t> fill(offsets.begin(), offsets.end() - 1), neighbours(offsets.back()), unique(n);
    for (const Triangle& tri : mesh.triangles) {
      for (int k = 0; k < 3; ++k) {
        int32_t& at = fill[tri[k]];
        neighbours[at++] = tri[(k + 1) % 3];
        neighbours[at++] = tri[(k + 2) % 3];
      }
    }
#pragma omp parallel for schedule(static)
    for (int32_t v = 0; v < n; ++v) {
      const auto first = neighbours.begin() + offsets[v], last = neighbours.begin() + offsets[v + 1];
      std::sort(first, last);
      unique[v] = static_cast<int32_t>(std::unique(first, last) - first);
    }
    t.push_back(Ms(t0, Clock::now()));
    kept += unique[n / 2];
  }
  return kept > 0 ? Median(t) : -1.0;
}

}  // namespace

void ServiceFloor(const NamedMesh& nm, int runs, double bare_ms) {
  const std::string draco = DracoUpload(nm.mesh);
  const Mesh decoded = DracoMesh::Decode(draco)->TakeWelded();  // the job's input
  const double tcp = LoopbackTcpMs(draco.size(), runs), neighbours = UniqueNeighboursMs(decoded, runs);
  std::printf("\n### The least a service adds to the codec, %s (medians of %d)\n\n| step | ms |\n|---|---|\n",
              nm.name.c_str(), runs);
  std::printf("| raw TCP on loopback: the upload's %.1f MB up and as many back (no gRPC) | %.1f |\n",
              draco.size() / 1e6, tcp);
  std::printf(
      "| unique neighbours of every vertex (counting sort, then sort + unique per vertex, all threads) | %.1f |\n",
      neighbours);
  std::printf("| sum | %.1f |\n", tcp + neighbours);
  std::printf("| what an overhead of 1.5x bare leaves besides the codec: 0.5 x %.0f ms | %.1f |\n", bare_ms,
              0.5 * bare_ms);
}

}  // namespace meshsmooth::bench
