#include "core/flows/implicit.h"

#include <Eigen/SparseCholesky>
#include <Eigen/SparseCore>
#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>
#include <vector>

#include "absl/strings/str_format.h"
#include "core/flows/flow_kernel.h"
#include "core/flows/operators.h"

namespace meshsmooth {

bool HasImplicitForm(FlowId id) { return id == FlowId::kLaplacian || id == FlowId::kBilaplacian || id == FlowId::kMcf; }

namespace flows {
namespace {

// The operator K of the flow (implicit.h).
enum class Operator : uint8_t { kUmbrella, kInverseDistance, kBilaplacian, kCotangent };

Operator OperatorOf(const FlowParams& p) {
  switch (*p.flow) {
    case FlowId::kBilaplacian:
      return Operator::kBilaplacian;
    case FlowId::kMcf:
      return Operator::kCotangent;
    default:
      return p.weights == UmbrellaWeights::kInverseDistance ? Operator::kInverseDistance : Operator::kUmbrella;
  }
}

Vec3 Times(const Vec3& a, const Vec3& b) { return {a.x * b.x, a.y * b.y, a.z * b.z}; }

// Sums fn(begin, end) over fixed blocks of [0, n), in block order: the same bits for any
// thread count.
template <typename Fn>
Vec3 SumBlocks(int32_t n, int threads, std::vector<Vec3>& partial, Fn&& fn) {
  partial.assign((n + kBlock - 1) / kBlock, Vec3{});
  ForBlocks(n, threads, [&](int32_t b, int32_t begin, int32_t end) { partial[b] = fn(begin, end); });
  Vec3 total;
  for (const Vec3& s : partial) total += s;
  return total;
}

// The cotangent weights of v's ring entries and its mixed Voronoi area, with the arithmetic of
// MeanCurvatureLanes (operators.h) one vertex at a time, H n = sum_e w_e (Q_e - P) / (4 area),
// but at needle triangles: K must stay positive semi-definite for conjugate gradients.
double CotangentRing(const int32_t* offsets, const int32_t* ring, const Vec3* pos, int32_t v, double* w) {
  const int32_t b = offsets[v], e = offsets[v + 1], count = e - b;
  if (count == 0) return 0.0;
  const Vec3 p = pos[v];
  for (int32_t k = 0; k < count; ++k) w[k] = 0.0;
  Vec3 a = pos[ring[e - 1]] - p;
  double la = SquaredNorm(a), area = 0.0;
  for (int32_t k = 0; k < count; ++k) {
    const Vec3 q = pos[ring[b + k]] - p;
    const double lq = SquaredNorm(q);
    const double dbl_area = Norm(Cross(a, q));
    const double dot_p = Dot(a, q), dot_a = la - dot_p, dot_q = lq - dot_p;
    // The test sees the triangle's three edges, so its three vertices agree on it.
    const bool ok = 1e-12 * (2.0 * (la + lq) - 2.0 * dot_p) < dbl_area;
    const double inv = ok ? 1.0 / dbl_area : 0.0;
    const double cot_a = std::clamp(dot_a * inv, -kCotMax, kCotMax);
    const double cot_q = std::clamp(dot_q * inv, -kCotMax, kCotMax);
    // The weights scale the triangle's three cotangents together so that none exceeds kCotMax.
    // Clamping each one alone, as the area does, can make c1 c2 + c2 c3 + c3 c1 negative (a
    // needle with angles near 0, 0 and 180 degrees: +kCotMax, +kCotMax, -kCotMax), and then the
    // triangle's stiffness, hence K and the system, is indefinite; scaled, it stays >= 0.
    const double largest = std::max({std::abs(dot_a), std::abs(dot_q), std::abs(dot_p)}) * inv;
    const double scale = largest > kCotMax ? inv * (kCotMax / largest) : inv;
    w[k] += dot_a * scale;                           // edge P-Q_k, angle at Q_{k-1}
    w[k == 0 ? count - 1 : k - 1] += dot_q * scale;  // edge P-Q_{k-1}, angle at Q_k
    const double voronoi = (lq * cot_a + la * cot_q) * 0.125;
    const double part = dbl_area * (dot_p < 0.0 ? 0.25 : 0.125);
    const double least = std::min(dot_p, std::min(dot_a, dot_q));
    if (ok) area += least < 0.0 ? part : voronoi;
    a = q;
    la = lq;
  }
  return area;
}

}  // namespace

absl::Status ConjugateGradients(int32_t n, int threads, absl::FunctionRef<Vec3(const Vec3*, Vec3*)> apply,
                                const double* diag, const Vec3& goal, Vec3* x, Vec3* r, int* iterations) {
  std::vector<Vec3> p(n), q(n);
  // r . r and r . z with z = r / diag, in block order.
  auto residual_sums = [&](int32_t begin, int32_t end) {
    std::pair<Vec3, Vec3> s;
    for (int32_t v = begin; v < end; ++v) {
      s.first += Times(r[v], r[v]);
      s.second += Times(r[v], r[v] * (1.0 / diag[v]));
    }
    return s;
  };
  std::vector<std::pair<Vec3, Vec3>> sums((n + kBlock - 1) / kBlock);
  auto reduce = [&](Vec3& rr, Vec3& rz) {
    rr = {}, rz = {};
    for (const auto& [a, b] : sums) rr += a, rz += b;
  };
  Vec3 rr, rz;
  ForBlocks(n, threads, [&](int32_t blk, int32_t begin, int32_t end) {
    for (int32_t v = begin; v < end; ++v) p[v] = r[v] * (1.0 / diag[v]);
    sums[blk] = residual_sums(begin, end);
  });
  reduce(rr, rz);
  auto done = [&](int c) { return (&rr.x)[c] <= (&goal.x)[c]; };
  // The largest residual against its goal over the coordinates (one done is at most 1, and the
  // loop runs while one is above): it must halve in every window of kCgStallWindow iterations.
  auto behind = [&] {
    double worst = 0.0;
    for (int c = 0; c < 3; ++c) worst = std::max(worst, (&rr.x)[c] / (&goal.x)[c]);
    return worst;
  };
  double best = behind(), window_best = std::numeric_limits<double>::infinity();
  int& k = *iterations;
  for (k = 0; !(done(0) && done(1) && done(2)); ++k) {
    if (k == kMaxCgIterations) {
      return absl::FailedPreconditionError(absl::StrFormat(
          "the implicit step's conjugate gradients did not converge in %d iterations; try a smaller step",
          kMaxCgIterations));
    }
    const Vec3 pq = apply(p.data(), q.data());
    Vec3 alpha;
    for (int c = 0; c < 3; ++c) {
      const double den = (&pq.x)[c];
      if (!done(c) && !(den > 0.0)) {
        return absl::FailedPreconditionError(
            absl::StrFormat("the implicit step's matrix is not positive definite (conjugate gradients met p.Ap = %g at "
                            "iteration %d)",
                            den, k));
      }
      (&alpha.x)[c] = done(c) ? 0.0 : (&rz.x)[c] / den;
    }
    ForBlocks(n, threads, [&](int32_t blk, int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) {
        x[v] += Times(alpha, p[v]);
        r[v] -= Times(alpha, q[v]);
      }
      sums[blk] = residual_sums(begin, end);
    });
    const Vec3 old_rz = rz;
    reduce(rr, rz);
    window_best = std::min(window_best, behind());
    if ((k + 1) % kCgStallWindow == 0) {
      if (!(window_best < 0.5 * best)) {
        return absl::FailedPreconditionError(absl::StrFormat(
            "the implicit step's conjugate gradients stopped converging (the residual did not halve in %d "
            "iterations, %d in all); try a smaller step",
            kCgStallWindow, k + 1));
      }
      best = window_best;
      window_best = std::numeric_limits<double>::infinity();
    }
    Vec3 beta;
    for (int c = 0; c < 3; ++c) {
      const double den = (&old_rz.x)[c];
      (&beta.x)[c] = den > 0.0 ? (&rz.x)[c] / den : 0.0;
    }
    ForBlocks(n, threads, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) p[v] = r[v] * (1.0 / diag[v]) + Times(beta, p[v]);
    });
  }
  for (int32_t v = 0; v < n; ++v) {
    if (!IsFinite(x[v])) return absl::FailedPreconditionError("the implicit step became NaN or infinite");
  }
  return absl::OkStatus();
}

class ImplicitStepper::Impl {
 public:
  Impl(const Topology& topo, const FlowParams& p, const uint8_t* role, ImplicitWeights weights, double h, int threads)
      : n_(topo.num_vertices()),
        offsets_(topo.ring_offsets.data()),
        ring_(topo.ring.data()),
        role_(role),
        strength_(p.strength.empty() ? nullptr : p.strength.data()),
        op_(OperatorOf(p)),
        lhs_(weights.lhs),
        rhs_(weights.rhs),
        tolerance_(p.cg_tolerance),
        h_(h),
        threads_(threads) {
    int32_t movable = 0;
    for (int32_t v = 0; v < n_; ++v) movable += role_[v] == kFree;
    solver_ = p.implicit_solver != ImplicitSolver::kAuto ? p.implicit_solver
              : movable <= kMaxDirectVertices            ? ImplicitSolver::kDirect
                                                         : ImplicitSolver::kCg;
    active_.assign(n_, 0);
    m_.assign(n_, 0.0);
    if (op_ == Operator::kInverseDistance || op_ == Operator::kCotangent) w_.assign(topo.ring.size(), 0.0);
    if (op_ == Operator::kCotangent) BuildReverse();
    if (solver_ == ImplicitSolver::kDirect) {
      row_.assign(n_, -1);
      for (int32_t v = 0; v < n_; ++v) {
        if (role_[v] != kFree) continue;
        row_[v] = static_cast<int32_t>(vertex_.size());
        vertex_.push_back(v);
      }
    }
  }

  absl::Status Step(const Vec3* cur, Vec3* next, bool next_holds_previous) {
    const bool constant = op_ == Operator::kUmbrella || op_ == Operator::kBilaplacian;
    if (!constant || steps_ == 0) {
      UpdateOperator(cur);
      // Factored before r_ exists: the factorisation's peak is the run's.
      if (solver_ == ImplicitSolver::kDirect) {
        if (absl::Status s = Factor(); !s.ok()) return s;
      }
    }
    // The right-hand side rhs K P into r_ (K over every vertex's position).
    r_.resize(n_);
    ApplyK(cur, r_.data());  // (its sum unused)
    ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) r_[v] = active_[v] ? r_[v] * rhs_ : Vec3{};
    });
    if (solver_ == ImplicitSolver::kDirect) {
      SolveDirect(next);
    } else if (absl::Status s = SolveCg(cur, next, next_holds_previous && steps_ > 0); !s.ok()) {
      return s;
    }
    ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) next[v] = active_[v] ? cur[v] + next[v] : cur[v];
    });
    ++steps_;
    return absl::OkStatus();
  }

  ImplicitSolver solver() const { return solver_; }
  int last_cg_iterations() const { return cg_iterations_; }

 private:
  double InverseStrength(int32_t v) const { return strength_ == nullptr ? 1.0 : 1.0 / strength_[v]; }

  // For each ring entry of a free vertex v towards a free k, where v sits in k's ring.
  void BuildReverse() {
    reverse_.assign(offsets_[n_], -1);
    ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) {
        if (role_[v] != kFree) continue;
        for (int32_t e = offsets_[v]; e < offsets_[v + 1]; ++e) {
          const int32_t k = ring_[e];
          if (role_[k] != kFree) continue;
          for (int32_t f = offsets_[k]; f < offsets_[k + 1]; ++f) {
            if (ring_[f] == v) {
              reverse_[e] = f;
              break;
            }
          }
        }
      }
    });
  }

  // M, the weights and the active vertices at positions `pos`; the diagonal of the system.
  void UpdateOperator(const Vec3* pos) {
    const double floor = 1e-9 * h_;  // U1's, operators.h
    ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) {
        active_[v] = 0;
        if (role_[v] != kFree) continue;
        const int32_t b = offsets_[v], e = offsets_[v + 1];
        double m = e - b;
        if (op_ == Operator::kInverseDistance) {
          m = 0.0;
          for (int32_t i = b; i < e; ++i) {
            w_[i] = 1.0 / std::max(Norm(pos[ring_[i]] - pos[v]), floor);
            m += w_[i];
          }
        } else if (op_ == Operator::kCotangent) {
          m = 4.0 * CotangentRing(offsets_, ring_, pos, v, &w_[b]);
        }
        m_[v] = m;
        active_[v] = m > 0.0;  // mcf: a vertex without area has no H n and does not move
      }
    });
    if (op_ == Operator::kCotangent) {
      // Each pair of free neighbours shares the mean of its two weights (they differ only at
      // degenerate triangles): K is symmetric. The smaller vertex writes both.
      ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
        for (int32_t v = begin; v < end; ++v) {
          if (role_[v] != kFree) continue;
          for (int32_t e = offsets_[v]; e < offsets_[v + 1]; ++e) {
            const int32_t f = reverse_[e];
            if (f < 0 || ring_[e] < v) continue;
            const double mean = 0.5 * (w_[e] + w_[f]);
            w_[e] = mean;
            w_[f] = mean;
          }
        }
      });
    }
    diag_.resize(n_);
    const double tl = lhs_;
    ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) {
        if (!active_[v]) {
          diag_[v] = 1.0;
          continue;
        }
        const int32_t b = offsets_[v], e = offsets_[v + 1];
        double k = e - b;
        if (op_ == Operator::kInverseDistance || op_ == Operator::kCotangent) {
          k = 0.0;
          for (int32_t i = b; i < e; ++i) k += w_[i];
        } else if (op_ == Operator::kBilaplacian) {
          for (int32_t i = b; i < e; ++i) {
            const int32_t valence = offsets_[ring_[i] + 1] - offsets_[ring_[i]];
            if (valence > 0) k += 1.0 / valence;
          }
        }
        diag_[v] = m_[v] * InverseStrength(v) + tl * k;
      }
    });
  }

  // y = K x on the active vertices (0 elsewhere); x is read at every vertex. With `mass`,
  // y = (M / s + theta lambda K) x instead, the system (x is then zero off the active vertices).
  // Returns the sum of x . y per coordinate, in block order.
  Vec3 ApplyK(const Vec3* x, Vec3* y, bool mass = false) {
    const Vec3* field = x;
    if (op_ == Operator::kBilaplacian) {
      // u = D^-1 L x = -U0(x) at every vertex with a ring (bilaplacian.cc: fixed ones too).
      u_.resize(n_);
      ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
        for (int32_t v = begin; v < end; ++v) {
          const int32_t b = offsets_[v], e = offsets_[v + 1];
          if (b == e) {
            u_[v] = {};
            continue;
          }
          Vec3 sum;
          for (int32_t i = b; i < e; ++i) sum += x[ring_[i]];
          u_[v] = x[v] - sum * (1.0 / (e - b));
        }
      });
      field = u_.data();
    }
    const bool weighted = !w_.empty();
    const double tl = lhs_;
    return SumBlocks(n_, threads_, partial_, [&](int32_t begin, int32_t end) {
      Vec3 dot;
      for (int32_t v = begin; v < end; ++v) {
        if (!active_[v]) {
          y[v] = {};
          continue;
        }
        const Vec3 f = field[v];
        Vec3 sum;
        for (int32_t i = offsets_[v], e = offsets_[v + 1]; i < e; ++i) {
          sum += weighted ? (f - field[ring_[i]]) * w_[i] : f - field[ring_[i]];
        }
        y[v] = mass ? x[v] * (m_[v] * InverseStrength(v)) + sum * tl : sum;
        dot += Times(x[v], y[v]);
      }
      return dot;
    });
  }

  // The lower triangle of the system over the free vertices (row_), built column by column in
  // place (no triplets: their list and Eigen's sorted copy took more than the matrix), in the
  // same pattern every step: entries of inactive vertices are explicit zeros, their diagonal 1.
  Eigen::SparseMatrix<double> Assemble() const {
    const int32_t size = static_cast<int32_t>(vertex_.size());
    const double tl = lhs_;
    std::vector<std::pair<int32_t, double>> column;
    // Column c's entries below the diagonal: A(k, v) = A(v, k) for the free k after v.
    auto gather = [&](int32_t c) {
      column.clear();
      const int32_t v = vertex_[c], b = offsets_[v], e = offsets_[v + 1];
      auto add = [&](int32_t k, double value) {
        if (row_[k] > c) column.emplace_back(row_[k], active_[v] && active_[k] ? tl * value : 0.0);
      };
      if (op_ != Operator::kBilaplacian) {
        for (int32_t i = b; i < e; ++i) add(ring_[i], w_.empty() ? -1.0 : -w_[i]);
      } else {
        // Row v of L D^-1 L: L_vj L_jk / d_j over j in v and its ring (the diagonal is in diag_).
        for (int32_t i = b; i < e; ++i) add(ring_[i], -1.0);  // j = v
        for (int32_t i = b; i < e; ++i) {
          const int32_t j = ring_[i], jb = offsets_[j], je = offsets_[j + 1];
          if (jb == je) continue;
          const double inv = 1.0 / (je - jb);
          add(j, -1.0);  // L_vj L_jj / d_j
          for (int32_t l = jb; l < je; ++l) {
            if (ring_[l] != v) add(ring_[l], inv);
          }
        }
      }
      std::stable_sort(column.begin(), column.end(), [](const auto& x, const auto& y) { return x.first < y.first; });
      size_t kept = 0;  // the sums of repeated rows (two-ring paths, a ring naming a vertex twice)
      for (size_t i = 0; i < column.size(); ++i) {
        if (kept > 0 && column[kept - 1].first == column[i].first) {
          column[kept - 1].second += column[i].second;
        } else {
          column[kept++] = column[i];
        }
      }
      column.resize(kept);
    };
    Eigen::SparseMatrix<double> a(size, size);
    Eigen::Index count = 0;
    for (int32_t c = 0; c < size; ++c) gather(c), count += 1 + static_cast<Eigen::Index>(column.size());
    a.resizeNonZeros(count);
    int* outer = a.outerIndexPtr();
    int* inner = a.innerIndexPtr();
    double* value = a.valuePtr();
    outer[0] = 0;
    for (int32_t c = 0; c < size; ++c) {
      gather(c);
      int32_t at = outer[c];
      inner[at] = c, value[at++] = diag_[vertex_[c]];
      for (const auto& [r, x] : column) inner[at] = r, value[at++] = x;
      outer[c + 1] = at;
    }
    return a;
  }

  // The factorisation: once for a constant matrix, else every step on the pattern analysed at
  // the first.
  absl::Status Factor() {
    const Eigen::SparseMatrix<double> a = Assemble();
    if (steps_ == 0) ldlt_.analyzePattern(a);
    ldlt_.factorize(a);
    if (ldlt_.info() != Eigen::Success) {
      return absl::FailedPreconditionError("the implicit step's matrix could not be factored");
    }
    return absl::OkStatus();
  }

  // The solve with the factorisation; the move goes into `d`.
  void SolveDirect(Vec3* d) {
    const int rows = static_cast<int>(vertex_.size());
    Eigen::MatrixX3d rhs(rows, 3);
    for (int r = 0; r < rows; ++r) {
      const Vec3& b = r_[vertex_[r]];
      rhs(r, 0) = b.x, rhs(r, 1) = b.y, rhs(r, 2) = b.z;
    }
    const Eigen::MatrixX3d x = ldlt_.solve(rhs);
    for (int32_t v = 0; v < n_; ++v) d[v] = {};
    for (int r = 0; r < rows; ++r) d[vertex_[r]] = {x(r, 0), x(r, 1), x(r, 2)};
  }

  // Conjugate gradients (ConjugateGradients) with the system's diagonal. x (the move) lives in
  // `d`; with `warm`, d holds the previous positions and the solve starts from the previous move
  // cur - d.
  absl::Status SolveCg(const Vec3* cur, Vec3* d, bool warm) {
    const Vec3 b2 = SumBlocks(n_, threads_, partial_, [&](int32_t begin, int32_t end) {
      Vec3 s;
      for (int32_t v = begin; v < end; ++v) s += Times(r_[v], r_[v]);
      return s;
    });
    // A residual no larger than that of moving every vertex by tolerance_ h counts as
    // converged too (a coordinate with nothing to move has b = 0).
    const double floor2 = SumBlocks(n_, threads_, partial_, [&](int32_t begin, int32_t end) {
                            double s = 0.0;
                            for (int32_t v = begin; v < end; ++v) {
                              if (active_[v]) s += std::pow(m_[v] * InverseStrength(v) * h_, 2);
                            }
                            return Vec3{s, 0.0, 0.0};
                          }).x;
    const double tol2 = tolerance_ * tolerance_;
    const Vec3 goal{tol2 * std::max(b2.x, floor2), tol2 * std::max(b2.y, floor2), tol2 * std::max(b2.z, floor2)};
    ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
      for (int32_t v = begin; v < end; ++v) d[v] = warm && active_[v] ? cur[v] - d[v] : Vec3{};
    });
    if (warm) {  // r = b - A x
      std::vector<Vec3> ax(n_);
      ApplyK(d, ax.data(), true);
      ForBlocks(n_, threads_, [&](int32_t, int32_t begin, int32_t end) {
        for (int32_t v = begin; v < end; ++v) r_[v] -= ax[v];
      });
    }
    return ConjugateGradients(
        n_, threads_, [&](const Vec3* p, Vec3* q) { return ApplyK(p, q, true); }, diag_.data(), goal, d, r_.data(),
        &cg_iterations_);
  }

  const int32_t n_;
  const int32_t* offsets_;
  const int32_t* ring_;
  const uint8_t* role_;
  const float* strength_;  // null: 1 everywhere (the free vertices' are > 0)
  const Operator op_;
  const double lhs_, rhs_, tolerance_, h_;
  const int threads_;
  ImplicitSolver solver_ = ImplicitSolver::kDirect;
  int steps_ = 0;
  int cg_iterations_ = 0;
  std::vector<uint8_t> active_;   // free, with M > 0
  std::vector<double> m_;         // M per vertex
  std::vector<double> w_;         // per ring entry (U1, mcf); empty: 1
  std::vector<int32_t> reverse_;  // mcf: the entry of the same edge in the neighbour's ring, or -1
  std::vector<double> diag_;      // the system's diagonal (1 where inactive)
  std::vector<Vec3> r_, u_;
  std::vector<Vec3> partial_;  // SumBlocks' per-block sums
  // The direct solver's rows: free vertices in order.
  std::vector<int32_t> row_, vertex_;
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>, Eigen::Lower> ldlt_;
};

ImplicitStepper::ImplicitStepper(const Topology& topo, const FlowParams& p, const uint8_t* role,
                                 ImplicitWeights weights, double h, int threads)
    : impl_(std::make_unique<Impl>(topo, p, role, weights, h, threads)) {}
ImplicitStepper::~ImplicitStepper() = default;

absl::Status ImplicitStepper::Step(const Vec3* cur, Vec3* next, bool next_holds_previous) {
  return impl_->Step(cur, next, next_holds_previous);
}
ImplicitSolver ImplicitStepper::solver() const { return impl_->solver(); }
int ImplicitStepper::last_cg_iterations() const { return impl_->last_cg_iterations(); }

}  // namespace flows
}  // namespace meshsmooth
