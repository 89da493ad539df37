// The costmap's loops, compiled: Costmap._footprint_hits and Costmap.trajectories_collide
// (host/nav/costmap.py) over poses and the obstacle discs near them, and Costmap._clear_rays
// along a scan's rays, which numpy can only run as whole-array passes over every sample.
//
// Same arithmetic as the numpy code, operation for operation (built with -ffp-contract=off, the
// same C library's hypot, cos and sin): the answers are the same bit for bit, only faster. Loaded
// with ctypes by jackson.host.nav.native; built by `make setup` (tools/build_compiled.py).
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace {

constexpr std::uint8_t kClear = 0, kNear = 1, kDeep = 2, kBlocked = 3;

// The obstacle discs the footprint test reads (Costmap._index_obstacles).
struct Obstacles {
  const std::int32_t* ids;      // padded by k cells, -1: no obstacle
  std::int64_t ids_size;        // (rows + 2k) (cols + 2k)
  std::int64_t padded_rows, padded_cols, k;
  const std::int64_t* offsets;  // flat offsets of the cells within reach of a pose's cell
  std::int64_t n_offsets;
  const double* xy;             // centres, (n, 2)
  const double* r;              // radii
};

struct Grid {
  double origin_x, origin_y, res;
  std::int64_t rows, cols;
};

struct Robot {
  double radius, circumscribed, x0, x1, y0, y1;
};

inline double clip(double v, double lo, double hi) { return v < lo ? lo : (v > hi ? hi : v); }

// Overlapping discs and the centre's clearance at one pose (clearance only when wanted).
// The obstacles within reach of each padded cell, gathered from the neighbour offsets the
// first time a pose lands in the cell, in offset order (the order of the numpy code's sums).
class Candidates {
 public:
  explicit Candidates(const Obstacles& o)
      : o_(o), first_(static_cast<std::size_t>(o.ids_size), -1),
        count_(static_cast<std::size_t>(o.ids_size), 0) {}

  const std::int32_t* at(std::int64_t cell, std::int32_t* n) {
    if (first_[cell] < 0) {
      first_[cell] = static_cast<std::int32_t>(pool_.size());
      for (std::int64_t j = 0; j < o_.n_offsets; ++j) {
        std::int64_t cand = cell + o_.offsets[j];
        cand = cand < 0 ? 0 : (cand > o_.ids_size - 1 ? o_.ids_size - 1 : cand);
        if (o_.ids[cand] >= 0) pool_.push_back(o_.ids[cand]);
      }
      count_[cell] = static_cast<std::int32_t>(pool_.size()) - first_[cell];
    }
    *n = count_[cell];
    return pool_.data() + first_[cell];
  }

 private:
  const Obstacles& o_;
  std::vector<std::int32_t> first_, count_, pool_;
};

// Overlapping discs and the centre's clearance at one pose (clearance only when wanted). With
// ``first_only`` it stops at the first overlap (count 1): enough where none is allowed.
inline std::int64_t hits_at(const Obstacles& o, Candidates& near, const Grid& g,
                            const Robot& rb, double x, double y, double yaw, double margin,
                            bool with_clearance, bool first_only, double* clearance) {
  const double kd = static_cast<double>(o.k);
  const auto col = static_cast<std::int64_t>(
      clip((x - g.origin_x) / g.res + kd, 0.0, static_cast<double>(o.padded_cols - 1)));
  const auto row = static_cast<std::int64_t>(
      clip((y - g.origin_y) / g.res + kd, 0.0, static_cast<double>(o.padded_rows - 1)));
  std::int32_t n = 0;
  const std::int32_t* ids = near.at(row * o.padded_cols + col, &n);
  std::int64_t count = 0;
  double clear = std::numeric_limits<double>::infinity();
  bool turned = false;  // cos and sin of the heading, once a disc needs the rectangle
  double c = 0.0, s = 0.0;
  for (std::int32_t j = 0; j < n; ++j) {
    const std::int32_t id = ids[j];
    const double dx = o.xy[2 * id] - x;
    const double dy = o.xy[2 * id + 1] - y;
    const double h = o.r[id];
    const double gap = std::hypot(dx, dy) - h;
    if (with_clearance && gap < clear) clear = gap;
    bool hit = gap < rb.radius + margin;
    const double grown = h + margin;
    if (!hit) {
      const double reach = rb.circumscribed + M_SQRT2 * grown - h;
      if (!(gap < reach)) continue;
      if (!turned) {
        c = std::cos(yaw);
        s = std::sin(yaw);
        turned = true;
      }
      const double lx = c * dx + s * dy;
      const double ly = c * dy - s * dx;
      hit = lx >= rb.x0 - grown && lx <= rb.x1 + grown && ly >= rb.y0 - grown &&
            ly <= rb.y1 + grown;
    }
    if (hit) {
      ++count;
      if (first_only) break;
    }
  }
  *clearance = clear;
  return count;
}

}  // namespace

extern "C" {

// Costmap._footprint_hits for n poses: counts[i], clearance[i] (inf without clearance).
void jackson_footprint_hits(std::int64_t n, const double* x, const double* y, const double* yaw,
                            const double* margin, std::int64_t margin_step,
                            std::int32_t with_clearance, const std::int32_t* ids,
                            std::int64_t padded_rows, std::int64_t padded_cols, std::int64_t k,
                            const std::int64_t* offsets, std::int64_t n_offsets,
                            const double* obstacle_xy, const double* obstacle_r,
                            const double* grid, const double* robot, std::int64_t* counts,
                            double* clearance) {
  const Obstacles o{ids,     padded_rows * padded_cols, padded_rows, padded_cols, k,
                    offsets, n_offsets,                 obstacle_xy, obstacle_r};
  const Grid g{grid[0], grid[1], grid[2], 0, 0};
  const Robot rb{robot[0], robot[1], robot[2], robot[3], robot[4], robot[5]};
  Candidates near(o);
  for (std::int64_t i = 0; i < n; ++i) {
    counts[i] = hits_at(o, near, g, rb, x[i], y[i], yaw[i], margin[i * margin_step],
                        with_clearance != 0, false, &clearance[i]);
  }
}

// Costmap.trajectories_collide after its escape rule: which of m trajectories of len poses
// (row-major) collide. A pose on a blocked cell collides; on a deep cell it collides unless its
// trajectory escapes (allowed > 0), when it is tested; a near pose is tested: more discs than
// allowed, or an escaping centre nearer than its floor, collides. A trajectory stops at its
// first collision.
void jackson_trajectories_collide(std::int64_t m, std::int64_t len, const double* x,
                                  const double* y, const double* yaw, const double* margin, const std::int64_t* allowed,
                                  const double* floor_m, const std::uint8_t* classes,
                                  std::int64_t grid_rows, std::int64_t grid_cols,
                                  const std::int32_t* ids, std::int64_t padded_rows,
                                  std::int64_t padded_cols, std::int64_t k,
                                  const std::int64_t* offsets, std::int64_t n_offsets,
                                  const double* obstacle_xy, const double* obstacle_r,
                                  const double* grid, const double* robot, std::uint8_t* hit) {
  const Obstacles o{ids,     padded_rows * padded_cols, padded_rows, padded_cols, k,
                    offsets, n_offsets,                 obstacle_xy, obstacle_r};
  const Grid g{grid[0], grid[1], grid[2], grid_rows, grid_cols};
  const Robot rb{robot[0], robot[1], robot[2], robot[3], robot[4], robot[5]};
  const double top_col = static_cast<double>(grid_cols) + 1.0;
  const double top_row = static_cast<double>(grid_rows) + 1.0;
  std::vector<std::uint8_t> cls(static_cast<std::size_t>(len));
  Candidates near(o);
  for (std::int64_t t = 0; t < m; ++t) {
    const bool escaping = allowed[t] > 0;
    const std::uint8_t lethal = escaping ? kBlocked : kDeep;
    std::uint8_t out = 0;
    // the lookup first, over the whole row (cheap), then the exact tests in order
    bool any_tested = false;
    for (std::int64_t j = 0; j < len; ++j) {
      const std::int64_t p = t * len + j;
      const auto col = static_cast<std::int64_t>(
          clip((x[p] - g.origin_x) / g.res + 1.0, 0.0, top_col));
      const auto row = static_cast<std::int64_t>(
          clip((y[p] - g.origin_y) / g.res + 1.0, 0.0, top_row));
      cls[j] = classes[row * (grid_cols + 2) + col];
      if (cls[j] >= lethal) {
        out = 1;
        break;
      }
      any_tested = any_tested || cls[j] != kClear;
    }
    for (std::int64_t j = 0; j < len && !out && any_tested; ++j) {
      if (cls[j] == kClear) continue;
      const std::int64_t p = t * len + j;
      // the C library's cosine and sine, which numpy's are (checked by the tests)
      double clearance = 0.0;
      const std::int64_t count = hits_at(o, near, g, rb, x[p], y[p], yaw[p], margin[t], escaping,
                                         !escaping, &clearance);
      if (count > allowed[t] || (count > 0 && clearance < floor_m[t])) out = 1;
    }
    hit[t] = out;
  }
}

// Costmap._clear_rays after its set-up: ray i's samples k = 0, 1, ... while k step <= stop[i]
// lie at (base + k u_i) cells from the grid's origin; each one on the grid is cleared.
void jackson_clear_rays(std::int64_t n_rays, const double* ux, const double* uy,
                        const double* stop, double base_x, double base_y, double step,
                        std::int64_t rows, std::int64_t cols, std::uint8_t* obstacle,
                        std::uint8_t free_value) {
  const double top_r = static_cast<double>(rows);
  const double top_c = static_cast<double>(cols);
  for (std::int64_t i = 0; i < n_rays; ++i) {
    for (std::int64_t k = 0;; ++k) {
      const double kd = static_cast<double>(k);
      if (!(kd * step <= stop[i])) break;
      const double c = std::floor(base_x + ux[i] * kd);
      const double r = std::floor(base_y + uy[i] * kd);
      if (r >= 0.0 && r < top_r && c >= 0.0 && c < top_c)
        obstacle[static_cast<std::int64_t>(r * top_c + c)] = free_value;
    }
  }
}

}  // extern "C"
