// The costmap's loops, compiled: Costmap._footprint_hits and Costmap.trajectories_collide
// (host/nav/costmap/footprint.py) over poses and the obstacle discs near them, and
// ObstacleLayer._clear_rays (host/nav/costmap/layers.py)
// along a scan's rays, which numpy can only run as whole-array passes over every sample.
//
// Same arithmetic as the numpy code, operation for operation (built with -ffp-contract=off, the
// same C library's hypot, cos and sin): the answers are the same bit for bit, only faster. The
// one shortcut numpy does not take, skipping a disc that is certainly out of reach before its
// hypot, cannot change an answer (hits_at). Loaded with ctypes by jackson.host.nav.native;
// built by `make setup` (tools/build_compiled.py).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <vector>

namespace {

constexpr std::uint8_t kClear = 0, kNear = 1, kDeep = 2, kBlocked = 3;
constexpr std::uint8_t kInscribed = 253, kLethal = 254, kNoInformation = 255;  // costs

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

// numpy's minimum, maximum and sign, signed zeros included (of two equal values minimum and
// maximum return the second; the sign of a zero is +0)
inline double np_min(double a, double b) { return a < b ? a : b; }
inline double np_max(double a, double b) { return a > b ? a : b; }
inline double np_sign(double a) { return a > 0.0 ? 1.0 : (a < 0.0 ? -1.0 : (a == a ? 0.0 : a)); }

// Python's min and max of two floats (the first unless the second is smaller / larger) and
// common.ramp.clamp
inline double py_min(double a, double b) { return b < a ? b : a; }
inline double py_max(double a, double b) { return b > a ? b : a; }

// common.ramp.ramp: one rate-limited step of one axis from u towards r
inline double ramp(double u, double r, double dt, double accel, double decel) {
  if (dt <= 0.0 || u == r) return u;
  if (u == 0.0 || (r != 0.0 && (u > 0.0) == (r > 0.0))) {
    const double bound = (std::fabs(r) >= std::fabs(u) ? accel : decel) * dt;
    return u + py_max(-bound, py_min(bound, r - u));
  }
  const double t_zero = std::fabs(u) / decel;
  if (dt < t_zero) return u - std::copysign(decel * dt, u);
  const double magnitude = py_min(std::fabs(r), accel * (dt - t_zero));
  return magnitude > 0.0 ? std::copysign(magnitude, r) : 0.0;
}

// np.linspace(start, stop, n) as numpy 2 computes it: i * step + start (i / div * delta +
// start when the step underflows to 0), the last one stop
inline void linspace(double start, double stop, std::int64_t n, double* y) {
  const std::int64_t div = n - 1;
  const double delta = stop - start;
  const double step = div > 0 ? delta / static_cast<double>(div) : 0.0;
  for (std::int64_t i = 0; i < n; ++i) {
    const double fi = static_cast<double>(i);
    double v;
    if (div <= 0)
      v = fi * delta;
    else if (step == 0.0)
      v = fi / static_cast<double>(div) * delta;
    else
      v = fi * step;
    y[i] = v + start;
  }
  if (n > 1) y[n - 1] = stop;
}

// window._sorted_distinct (np.unique of a nondecreasing array; np.unique itself otherwise)
inline std::vector<double> sorted_distinct(std::vector<double> a) {
  if (!std::is_sorted(a.begin(), a.end())) std::sort(a.begin(), a.end());
  std::vector<double> out;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (i == 0 || a[i] != a[i - 1]) out.push_back(a[i]);
  return out;
}

// numpy's float -> int64 cast on x86: out of range (and NaN) gives the smallest int64
inline std::int64_t to_int(double d) {
  return d >= -9.2233720368547758e18 && d < 9.2233720368547758e18
             ? static_cast<std::int64_t>(d)
             : std::numeric_limits<std::int64_t>::min();
}

// dwb.core.distance.cell_index of one point: the flat index of its cell clipped onto the grid,
// and whether it lies on the grid
inline std::int64_t cell_index(double x, double y, const Grid& g, std::uint8_t* on_grid) {
  std::int64_t c = to_int(std::floor((x - g.origin_x) / g.res));
  std::int64_t r = to_int(std::floor((y - g.origin_y) / g.res));
  *on_grid = r >= 0 && r < g.rows && c >= 0 && c < g.cols;
  r = std::min(std::max(r, std::int64_t{0}), g.rows - 1);
  c = std::min(std::max(c, std::int64_t{0}), g.cols - 1);
  return r * g.cols + c;
}

// window.velocity_profile for one target r at the n times t: u(t) ramping from u0 towards r
inline void velocity_profile(double u0, double r, const double* t, std::int64_t n, double accel,
                             double decel, double* u) {
  const bool same_side = u0 == 0.0 || (r != 0.0 && ((r > 0.0) == (u0 > 0.0)));
  if (same_side) {
    const double rate = std::fabs(r) >= std::fabs(u0) ? accel : decel;
    const double gap = r - u0;
    const double sign = np_sign(gap), size = std::fabs(gap);
    for (std::int64_t j = 0; j < n; ++j) u[j] = u0 + sign * np_min(size, rate * t[j]);
    return;
  }
  // through zero (or to zero): brake at decel until t0, then speed up towards r
  const double t0 = std::fabs(u0) / decel;
  const double brake = std::copysign(decel, u0);
  const double sign = np_sign(r), size = std::fabs(r);
  for (std::int64_t j = 0; j < n; ++j) {
    const double braking = u0 != 0.0 ? u0 - brake * t[j] : 0.0;
    u[j] = t[j] < t0 ? braking : sign * np_min(size, accel * np_max(t[j] - t0, 0.0));
  }
}

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
    if (!with_clearance) {
      // a disc certainly beyond the rectangle test's reach (so beyond the disc test's too)
      // needs no hypot: its squared distance exceeds (reach + h)^2 by far more than the
      // rounding of either side, so hypot - h >= reach would hold as well
      const double far = rb.circumscribed + M_SQRT2 * (h + margin);  // reach + h
      if (dx * dx + dy * dy > far * far * (1.0 + 1e-9)) continue;
    }
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

// One trajectory's test (jackson_trajectories_collide's rule), the obstacle candidates shared
// by all the trajectories of one call.
class Trajectory {
 public:
  Trajectory(const Obstacles& o, const Grid& g, const Robot& rb, const std::uint8_t* classes,
             std::int64_t max_len)
      : o_(o), g_(g), rb_(rb), classes_(classes), near_(o),
        cls_(static_cast<std::size_t>(max_len)) {}

  std::uint8_t collides(const double* x, const double* y, const double* yaw, std::int64_t len,
                        double margin, std::int64_t allowed, double floor_m) {
    const bool escaping = allowed > 0;
    const std::uint8_t lethal = escaping ? kBlocked : kDeep;
    const double top_col = static_cast<double>(g_.cols) + 1.0;
    const double top_row = static_cast<double>(g_.rows) + 1.0;
    // the lookup first, over the whole row (cheap), then the exact tests in order
    bool any_tested = false;
    for (std::int64_t j = 0; j < len; ++j) {
      const auto col =
          static_cast<std::int64_t>(clip((x[j] - g_.origin_x) / g_.res + 1.0, 0.0, top_col));
      const auto row =
          static_cast<std::int64_t>(clip((y[j] - g_.origin_y) / g_.res + 1.0, 0.0, top_row));
      cls_[j] = classes_[row * (g_.cols + 2) + col];
      if (cls_[j] >= lethal) return 1;
      any_tested = any_tested || cls_[j] != kClear;
    }
    for (std::int64_t j = 0; j < len && any_tested; ++j) {
      if (cls_[j] == kClear) continue;
      // the C library's cosine and sine, which numpy's are (checked by the tests)
      double clearance = 0.0;
      const std::int64_t count = hits_at(o_, near_, g_, rb_, x[j], y[j], yaw[j], margin, escaping,
                                         !escaping, &clearance);
      if (count > allowed || (count > 0 && clearance < floor_m)) return 1;
    }
    return 0;
  }

 private:
  const Obstacles& o_;
  const Grid& g_;
  const Robot& rb_;
  const std::uint8_t* classes_;
  Candidates near_;
  std::vector<std::uint8_t> cls_;
};

// The squared distance transform (scipy.ndimage.distance_transform_edt(~feature) squared):
// g[i] the squared distance [cells^2] from cell i's centre to the nearest feature cell's centre;
// false (g unset) without a feature. Felzenszwalb and Huttenlocher's two passes: along each
// column the distance to the nearest feature of that column, then along each row the lower
// envelope of the parabolas (c - c')^2 + g(c')^2, the envelope's breakpoints compared as exact
// fractions of whole numbers. g: rows x cols (int64); v: cols (int64); zn, zd: cols + 1 (int64);
// row: cols (int64) scratch.
inline bool squared_distances(std::int64_t rows, std::int64_t cols, const std::uint8_t* feature,
                              std::int64_t* g, std::int64_t* v, std::int64_t* zn,
                              std::int64_t* zd) {
  const std::int64_t far = rows + cols + 1;  // farther than any feature of the grid
  bool any = false;
  for (std::int64_t r = 0; r < rows; ++r) {  // down the columns, a row at a time
    for (std::int64_t c = 0; c < cols; ++c) {
      const std::int64_t i = r * cols + c;
      if (feature[i]) {
        g[i] = 0;
        any = true;
      } else {
        g[i] = (r > 0 && g[i - cols] < far) ? g[i - cols] + 1 : far;
      }
    }
  }
  if (!any) return false;
  for (std::int64_t r = rows - 2; r >= 0; --r) {  // and up them
    for (std::int64_t c = 0; c < cols; ++c) {
      const std::int64_t i = r * cols + c;
      if (g[i + cols] + 1 < g[i]) g[i] = g[i + cols] + 1;
    }
  }
  std::vector<std::int64_t> row(static_cast<std::size_t>(cols));
  for (std::int64_t r = 0; r < rows; ++r) {
    std::int64_t* out = g + r * cols;
    for (std::int64_t q = 0; q < cols; ++q) row[q] = out[q];  // the column pass, kept
    std::int64_t k = -1;  // the envelope's last parabola; breakpoint j is zn[j] / zd[j]
    for (std::int64_t q = 0; q < cols; ++q) {
      if (row[q] >= far) continue;  // no feature in this column
      const std::int64_t fq = row[q] * row[q] + q * q;
      while (k >= 0) {
        const std::int64_t p = v[k];
        const std::int64_t num = fq - (row[p] * row[p] + p * p);
        const std::int64_t den = 2 * (q - p);
        if (k > 0 && num * zd[k] <= zn[k] * den) {
          --k;  // parabola p lies above the envelope from where it would start
          continue;
        }
        ++k;
        v[k] = q;
        zn[k] = num;
        zd[k] = den;
        break;
      }
      if (k < 0) {
        k = 0;
        v[0] = q;
        zn[0] = 0;
        zd[0] = 0;  // from -infinity
      }
    }
    std::int64_t j = 0;
    for (std::int64_t q = 0; q < cols; ++q) {
      while (j < k && zn[j + 1] <= q * zd[j + 1]) ++j;  // breakpoint j + 1 at or before q
      const std::int64_t p = v[j];
      out[q] = (q - p) * (q - p) + row[p] * row[p];
    }
  }
  return true;
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
                                  const double* y, const double* yaw, const double* margin,
                                  const std::int64_t* allowed, const double* floor_m,
                                  const std::uint8_t* classes, std::int64_t grid_rows,
                                  std::int64_t grid_cols, const std::int32_t* ids,
                                  std::int64_t padded_rows, std::int64_t padded_cols,
                                  std::int64_t k, const std::int64_t* offsets,
                                  std::int64_t n_offsets, const double* obstacle_xy,
                                  const double* obstacle_r, const double* grid,
                                  const double* robot, std::uint8_t* hit) {
  const Obstacles o{ids,     padded_rows * padded_cols, padded_rows, padded_cols, k,
                    offsets, n_offsets,                 obstacle_xy, obstacle_r};
  const Grid g{grid[0], grid[1], grid[2], grid_rows, grid_cols};
  const Robot rb{robot[0], robot[1], robot[2], robot[3], robot[4], robot[5]};
  Trajectory test(o, g, rb, classes, len);
  for (std::int64_t t = 0; t < m; ++t) {
    hit[t] = test.collides(x + t * len, y + t * len, yaw + t * len, len, margin[t], allowed[t],
                           floor_m[t]);
  }
}

// DwbPlanner's roll-outs tested where they are (Rollouts.at_strides then
// jackson_trajectories_collide, without the arrays between): roll-out t steps ds[iv[t], i] along
// (cos, sin)[iw[t], i] from (x0, y0), its heading yaw[iw[t], j] at pose j, and is read at poses
// 0, s, 2 s, ... and K (s = stride[t]). Its positions are numpy's: the steps' running sums
// (first step, then one addition per step) plus the start. ds is (V, K), cs the W cosine rows
// then the W sine rows (2 W, K), yaw (W, K + 1). With stop_at_clear the roll-outs are tested
// in their order up to the first that does not collide, whose index is returned (hit is then
// set up to it); m when every one collides, or without stop_at_clear.
std::int64_t jackson_rollouts_collide(std::int64_t m, std::int64_t steps, const std::int64_t* iv,
                              const std::int64_t* iw, const std::int64_t* stride,
                              const double* ds, const double* cs, std::int64_t w,
                              const double* yaw, double x0, double y0, const double* margin,
                              const std::int64_t* allowed, const double* floor_m,
                              const std::uint8_t* classes, std::int64_t grid_rows,
                              std::int64_t grid_cols, const std::int32_t* ids,
                              std::int64_t padded_rows, std::int64_t padded_cols, std::int64_t k,
                              const std::int64_t* offsets, std::int64_t n_offsets,
                              const double* obstacle_xy, const double* obstacle_r,
                              const double* grid, const double* robot,
                              std::int64_t stop_at_clear, std::uint8_t* hit) {
  const Obstacles o{ids,     padded_rows * padded_cols, padded_rows, padded_cols, k,
                    offsets, n_offsets,                 obstacle_xy, obstacle_r};
  const Grid g{grid[0], grid[1], grid[2], grid_rows, grid_cols};
  const Robot rb{robot[0], robot[1], robot[2], robot[3], robot[4], robot[5]};
  Trajectory test(o, g, rb, classes, steps + 1);
  std::vector<double> px(static_cast<std::size_t>(steps + 1));
  std::vector<double> py(px.size()), pyaw(px.size());
  for (std::int64_t t = 0; t < m; ++t) {
    const double* d = ds + iv[t] * steps;
    const double* c = cs + iw[t] * steps;
    const double* s = cs + (w + iw[t]) * steps;
    const double* h = yaw + iw[t] * (steps + 1);
    const std::int64_t every = stride[t];
    std::int64_t n = 0;
    px[0] = 0.0 + x0;
    py[0] = 0.0 + y0;
    pyaw[0] = h[0];
    n = 1;
    double ax = 0.0, ay = 0.0;
    std::int64_t left = every;  // steps to the next pose read
    for (std::int64_t i = 0; i < steps; ++i) {
      const double sx = d[i] * c[i];
      const double sy = d[i] * s[i];
      if (i == 0) {
        ax = sx;
        ay = sy;
      } else {
        ax += sx;
        ay += sy;
      }
      const std::int64_t j = i + 1;  // the pose after this step
      if (--left == 0 || j == steps) {
        left = every;
        px[n] = ax + x0;
        py[n] = ay + y0;
        pyaw[n] = h[j];
        ++n;
      }
    }
    hit[t] = test.collides(px.data(), py.data(), pyaw.data(), n, margin[t], allowed[t],
                           floor_m[t]);
    if (stop_at_clear && !hit[t]) return t;
  }
  return m;
}

// ObstacleLayer._clear_rays after its set-up: ray i's samples k = 0, 1, ... while k step <= stop[i]
// lie at (base + k u_i) cells from the grid's origin; each one on the grid is cleared.
// Only the samples a ray can have on the grid are visited: the span of k over which its line
// crosses the grid's slabs, widened by two samples at each end (every sample is still tested),
// so a 3 m ray leaving a 3 m window halfway costs half. floor() of a cell coordinate is taken
// by truncation (exact for |v| < 2^63; the coordinates are a few thousand cells at most), not
// by the C library's call.
inline double floor_of(double v) {
  const double t = static_cast<double>(static_cast<std::int64_t>(v));
  return t > v ? t - 1.0 : t;
}

// The k (>= 0) from which, and up to which, base + k u can lie in [0, top): the whole range
// [0, inf) when u is 0 and base lies in it, none (lo > hi) when it does not.
inline void slab(double base, double u, double top, double* lo, double* hi) {
  if (u > 0.0) {
    *lo = std::max(*lo, std::floor(-base / u) - 2.0);
    *hi = std::min(*hi, std::ceil((top - base) / u) + 2.0);
  } else if (u < 0.0) {
    *lo = std::max(*lo, std::floor((top - base) / u) - 2.0);
    *hi = std::min(*hi, std::ceil(-base / u) + 2.0);
  } else if (!(base >= 0.0 && base < top)) {
    *hi = -1.0;
  }
}

void jackson_clear_rays(std::int64_t n_rays, const double* ux, const double* uy,
                        const double* stop, double base_x, double base_y, double step,
                        std::int64_t rows, std::int64_t cols, std::uint8_t* obstacle,
                        std::uint8_t free_value) {
  const double top_r = static_cast<double>(rows);
  const double top_c = static_cast<double>(cols);
  for (std::int64_t i = 0; i < n_rays; ++i) {
    // no further than the ray's own end (nor a negative or NaN end: no sample)
    double lo = 0.0, hi = std::floor(stop[i] / step) + 2.0;
    if (!(hi >= 0.0)) continue;
    slab(base_x, ux[i], top_c, &lo, &hi);
    slab(base_y, uy[i], top_r, &lo, &hi);
    if (!(lo <= hi)) continue;  // the line misses the grid
    // the last sample: the largest k with k step <= stop (the loop's own test, so the same k)
    std::int64_t last = static_cast<std::int64_t>(std::floor(stop[i] / step));
    while (last >= 0 && !(static_cast<double>(last) * step <= stop[i])) --last;
    while (static_cast<double>(last + 1) * step <= stop[i]) ++last;
    last = std::min(last, static_cast<std::int64_t>(hi));
    const double bx = base_x, by = base_y, dx = ux[i], dy = uy[i];
    for (std::int64_t k = static_cast<std::int64_t>(lo); k <= last; ++k) {
      const double kd = static_cast<double>(k);
      const double c = floor_of(bx + dx * kd);
      const double r = floor_of(by + dy * kd);
      if (r >= 0.0 && r < top_r && c >= 0.0 && c < top_c)
        obstacle[static_cast<std::int64_t>(r * top_c + c)] = free_value;
    }
  }
}

// DWB's distance maps (jackson.host.nav.dwb.core.distance.grid_distance over grid_graph): one
// breadth-first search from every source cell at once through the 4-connected cells that are
// free (an edge joins two adjacent free cells); distance[i] is the Manhattan distance in cells
// along that search to the nearest source, rows x cols where none reaches. The distances are
// whole numbers, so any breadth-first order gives the same ones. queue: rows x cols scratch.
void jackson_grid_distance(std::int64_t rows, std::int64_t cols, const std::uint8_t* free_cell,
                           const std::uint8_t* source, double* distance, std::int64_t* queue) {
  const std::int64_t n = rows * cols;
  std::int64_t head = 0;
  std::int64_t tail = 0;
  for (std::int64_t i = 0; i < n; ++i) {
    distance[i] = source[i] ? 0.0 : -1.0;
    if (source[i]) queue[tail++] = i;
  }
  while (head < tail) {
    const std::int64_t i = queue[head++];
    if (!free_cell[i]) continue;  // a source on an obstacle reaches nothing
    const std::int64_t r = i / cols;
    const std::int64_t c = i - r * cols;
    const double next = distance[i] + 1.0;
    const std::int64_t around[4] = {r > 0 ? i - cols : -1, c > 0 ? i - 1 : -1,
                                    c + 1 < cols ? i + 1 : -1, r + 1 < rows ? i + cols : -1};
    for (const std::int64_t j : around) {
      if (j >= 0 && free_cell[j] && distance[j] < 0.0) {
        distance[j] = next;
        queue[tail++] = j;
      }
    }
  }
  const double unreached = static_cast<double>(n);
  for (std::int64_t i = 0; i < n; ++i)
    if (distance[i] < 0.0) distance[i] = unreached;
}

// The Euclidean distance transform (scipy.ndimage.distance_transform_edt(~feature)): each cell's
// distance [cells] to the nearest feature cell's centre, the square root of a whole number of
// squared cells, so exactly the double scipy returns; +inf everywhere when there is no feature.
// g: rows x cols scratch (int64); v: cols (int64); zn, zd: cols + 1 (int64).
void jackson_edt(std::int64_t rows, std::int64_t cols, const std::uint8_t* feature,
                 double* distance, std::int64_t* g, std::int64_t* v, std::int64_t* zn,
                 std::int64_t* zd) {
  if (!squared_distances(rows, cols, feature, g, v, zn, zd)) {
    for (std::int64_t i = 0; i < rows * cols; ++i) distance[i] = HUGE_VAL;
    return;
  }
  for (std::int64_t i = 0; i < rows * cols; ++i) distance[i] = std::sqrt(static_cast<double>(g[i]));
}

// Costmap._combined over rows x cols cells: the static and obstacle layers combined into master
// (the obstacle's cost where it is known and the static one is unknown or lower), lethal the
// master's lethal cells, dist the distance of every cell to the nearest lethal cell's centre [m]
// (the transform's, times res; +inf beyond far or without a lethal cell), and the inflation's
// cost raised into master: into a known cell below it, into an unknown cell where it is at least
// inscribed. The inflation cost at d2 squared cells is cost[d2] (numpy's inflation_cost of that
// very distance) for d2 < n_cost, 0 beyond. Scratch as jackson_edt's, g holding d2 after.
void jackson_combine_inflate(std::int64_t rows, std::int64_t cols, const std::uint8_t* stat,
                             const std::uint8_t* obstacle, double res, double far,
                             const std::uint8_t* cost, std::int64_t n_cost,
                             std::uint8_t* master, std::uint8_t* lethal, double* dist,
                             std::int64_t* g, std::int64_t* v, std::int64_t* zn,
                             std::int64_t* zd) {
  const std::int64_t n = rows * cols;
  for (std::int64_t i = 0; i < n; ++i) {
    std::uint8_t m = stat[i];
    const std::uint8_t o = obstacle[i];
    if (o != kNoInformation && (m == kNoInformation || o > m)) m = o;
    master[i] = m;
    lethal[i] = m == kLethal;
  }
  const bool any = squared_distances(rows, cols, lethal, g, v, zn, zd);
  for (std::int64_t i = 0; i < n; ++i) {
    double d = HUGE_VAL;
    std::uint8_t inflated = 0;
    if (any) {
      d = std::sqrt(static_cast<double>(g[i])) * res;
      if (d > far) d = HUGE_VAL;
      else if (g[i] < n_cost) inflated = cost[g[i]];
    }
    dist[i] = d;
    const std::uint8_t m = master[i];
    if (m == kNoInformation ? inflated >= kInscribed : inflated > m) master[i] = inflated;
  }
}

// DWB's roll-out tables (jackson.host.nav.dwb.core.rollouts.build_rollouts, after the
// granularity rule): each distinct linear target's velocity profile at the k + 1 pose times t
// as the path length of each step, ds (nv, k); each distinct angular target's as the heading
// at each pose, yaw (nw, k + 1), the trapezoidal rule's running sum from yaw0, and at the
// middle of each step, mid (nw, k). numpy's operations, in numpy's order.
void jackson_dwb_tables(std::int64_t nv, const double* uv, double v0, double accel_v,
                        double decel_v, std::int64_t nw, const double* uw, double w0,
                        double accel_w, double decel_w, std::int64_t k, const double* t,
                        double dt, double yaw0, double* ds, double* yaw, double* mid) {
  std::vector<double> u(static_cast<std::size_t>(k + 1));
  for (std::int64_t i = 0; i < nv; ++i) {
    velocity_profile(v0, uv[i], t, k + 1, accel_v, decel_v, u.data());
    double* d = ds + i * k;
    for (std::int64_t j = 0; j < k; ++j) d[j] = 0.5 * (u[j + 1] + u[j]) * dt;
  }
  for (std::int64_t i = 0; i < nw; ++i) {
    velocity_profile(w0, uw[i], t, k + 1, accel_w, decel_w, u.data());
    double* h = yaw + i * (k + 1);
    double* md = mid + i * k;
    h[0] = 0.0 + yaw0;
    double turned = 0.0;
    for (std::int64_t j = 0; j < k; ++j) {
      const double step = 0.5 * (u[j + 1] + u[j]) * dt;
      turned = j == 0 ? step : turned + step;
      h[j + 1] = turned + yaw0;
      md[j] = h[j] + 0.5 * step;
    }
  }
}

// Rollouts.coarse: roll-out t (ramps iv[t], iw[t]; ds (V, k), cs the W cosine rows then the W
// sine rows (2 W, k)) at poses 0, stride, 2 stride, ... and k: its position there, the running
// sum of its steps plus the start, x (B + 1, m) and y, and its path length between two of them,
// the difference of the running sums of |ds|, length (B, m).
void jackson_dwb_coarse(std::int64_t m, std::int64_t k, std::int64_t stride,
                        const std::int64_t* iv, const std::int64_t* iw, const double* ds,
                        const double* cs, std::int64_t w, double x0, double y0, double* x,
                        double* y, double* length) {
  for (std::int64_t t = 0; t < m; ++t) {
    const double* d = ds + iv[t] * k;
    const double* c = cs + iw[t] * k;
    const double* s = cs + (w + iw[t]) * k;
    x[t] = 0.0 + x0;
    y[t] = 0.0 + y0;
    double ax = 0.0, ay = 0.0, run = 0.0, before = 0.0;
    std::int64_t b = 0, left = stride;  // steps left in this block
    for (std::int64_t i = 0; i < k; ++i) {
      const double sx = d[i] * c[i];
      const double sy = d[i] * s[i];
      const double step = std::fabs(d[i]);
      if (i == 0) {
        ax = sx;
        ay = sy;
        run = step;
      } else {
        ax += sx;
        ay += sy;
        run += step;
      }
      if (--left == 0 || i + 1 == k) {  // the pose after this step ends a block
        left = stride;
        ++b;
        x[b * m + t] = ax + x0;
        y[b * m + t] = ay + y0;
        length[(b - 1) * m + t] = run - before;
        before = run;
      }
    }
  }
}

// base_obstacle.collisions' plan for m roll-outs of k steps of dt (targets v, w; current
// velocity v0, w0): each one's stride, the largest power of two that keeps every point of the
// robot (circumscribed radius r) within half a cell between two poses tested, capped at k,
// and its margin, half the farthest sweep between two tested poses of its stride group; and
// whether it comes within reach of an obstacle: at one of its B coarse poses (x, y: (B + 1,
// m), the last one unread) the clear reach (Costmap.clear_reach_m, over the grid of rows x
// cols padded by one cell, origin and resolution in grid) is at most the path length of the
// block that follows.
void jackson_dwb_collision_plan(std::int64_t m, const double* v, const double* w, double v0,
                                double w0, double r, double dt, double half_cell, std::int64_t k,
                                std::int64_t blocks, const double* x, const double* y,
                                const double* length, const double* reach, const double* grid,
                                std::int64_t rows, std::int64_t cols, std::int64_t* group,
                                double* margin, std::uint8_t* near) {
  std::vector<double> per_step(static_cast<std::size_t>(m));
  std::vector<double> widest(64, -1.0);  // the farthest step per group (log2 of the group)
  const double av0 = std::fabs(v0), aw0 = std::fabs(w0);
  for (std::int64_t t = 0; t < m; ++t) {
    const double speed = np_max(std::fabs(v[t]), av0) + np_max(std::fabs(w[t]), aw0) * r;
    per_step[t] = speed * dt;
    const double stride =
        np_min(static_cast<double>(k), std::floor(half_cell / np_max(per_step[t], 1e-12)));
    const auto whole = static_cast<std::int64_t>(np_max(stride, 1.0));
    std::int64_t g = 1, bits = 0;
    while (g <= whole / 2) {
      g *= 2;
      ++bits;
    }
    group[t] = g;
    if (!(per_step[t] <= widest[bits])) widest[bits] = per_step[t];
  }
  for (std::int64_t t = 0; t < m; ++t) {
    std::int64_t bits = 0;
    while ((std::int64_t{1} << bits) < group[t]) ++bits;
    const double sweep = static_cast<double>(group[t]) * widest[bits];
    margin[t] = 0.5 * (half_cell < sweep ? half_cell : sweep);
  }
  const double top_col = static_cast<double>(cols) + 1.0;
  const double top_row = static_cast<double>(rows) + 1.0;
  for (std::int64_t t = 0; t < m; ++t) {
    near[t] = 0;
    for (std::int64_t b = 0; b < blocks; ++b) {
      const double px = x[b * m + t], py = y[b * m + t];
      const auto col = static_cast<std::int64_t>(clip((px - grid[0]) / grid[2] + 1.0, 0.0, top_col));
      const auto row = static_cast<std::int64_t>(clip((py - grid[1]) / grid[2] + 1.0, 0.0, top_row));
      if (reach[row * (cols + 2) + col] <= length[b * m + t] + 1e-9) {
        near[t] = 1;
        break;
      }
    }
  }
}

// DwbPlanner.compute's cycle before the critics, in one call: window.sample_targets, then
// rollouts.build_rollouts (the granularity rule, the distinct targets, jackson_dwb_tables, the
// cosine and sine of the mid-step headings), Rollouts.coarse and critics.base.Batch.of with
// its forward cells at the nf distances fd. numpy's operations in numpy's order.
//   p: sim_time, linear and angular granularity, min_vel_x, min_speed_theta, max_vel_x,
//      max_vel_theta, acc_lim_x, decel_lim_x, acc_lim_theta, decel_lim_theta
//   state: v0, w0, x0, y0, yaw0;  grid: origin x, origin y, resolution (rows x cols)
//   cap: the buffers' room for M targets, V and W distinct targets, K steps
// Writes sizes (M, V, W, K, B) and, compactly from each offset, the float arrays v, w, t, ds,
// yaw, cos_sin, coarse x, coarse y, coarse length, yaw_end, cos_end, sin_end and v_brake (fo),
// the int64 arrays iv, iw, end_cell and the nf x M forward cells (io), the bytes end_on_grid
// and forward on-grid (bo). Returns 0, or -1 when a capacity is too small or a value is NaN
// (the caller then takes numpy's path).
std::int64_t jackson_dwb_front(const double* p, std::int64_t vx_samples,
                               std::int64_t vtheta_samples, std::int64_t stride,
                               const double* state, const double* grid, std::int64_t rows,
                               std::int64_t cols, std::int64_t nf, const double* fd,
                               const std::int64_t* cap, std::int64_t* sizes, double* f,
                               const std::int64_t* fo, std::int64_t* n, const std::int64_t* io,
                               std::uint8_t* b, const std::int64_t* bo) {
  const double sim_time = p[0], lin_gran = p[1], ang_gran = p[2], min_vel_x = p[3],
               min_speed_theta = p[4], max_v = p[5], max_w = p[6];
  const double acc_x = p[7], dec_x = p[8], acc_th = p[9], dec_th = p[10];
  for (int i = 0; i < 5; ++i)
    if (std::isnan(state[i])) return -1;
  if (vx_samples < 1 || vtheta_samples < 1 || stride < 1) return -1;
  // the dynamic window (window.dynamic_window)
  const double v0 = py_min(py_max(state[0], -max_v), max_v);
  const double w0 = py_min(py_max(state[1], -max_w), max_w);
  const double v_min = py_min(min_vel_x, max_v);
  const double v_lo = py_max(ramp(v0, v_min, sim_time, acc_x, dec_x), v_min);
  const double v_hi = py_max(ramp(v0, max_v, sim_time, acc_x, dec_x), v_min);
  const double w_lo = ramp(w0, -max_w, sim_time, acc_th, dec_th);
  const double w_hi = ramp(w0, max_w, sim_time, acc_th, dec_th);
  // the targets (window.sample_targets)
  std::vector<double> lin(static_cast<std::size_t>(vx_samples));
  std::vector<double> ang(static_cast<std::size_t>(vtheta_samples));
  linspace(v_lo, v_hi, vx_samples, lin.data());
  linspace(w_lo, w_hi, vtheta_samples, ang.data());
  const std::vector<double> vs = sorted_distinct(lin);
  std::vector<double> ws = sorted_distinct(ang);
  if (w_lo <= 0.0 && 0.0 <= w_hi && std::find(ws.begin(), ws.end(), 0.0) == ws.end())
    ws.insert(std::lower_bound(ws.begin(), ws.end(), 0.0), 0.0);
  const double w_min = py_min(min_speed_theta, max_w);
  std::vector<double> snapped(ws);
  for (double& x : snapped)
    if (x != 0.0 && std::fabs(x) < w_min) x = std::copysign(w_min, x);
  const std::vector<double> in_place = sorted_distinct(snapped);
  std::int64_t m = 0;
  bool any_in_place = false, any_moving = false;
  for (const double vi : vs) {
    const bool still = std::fabs(vi) < 1e-9;
    m += static_cast<std::int64_t>(still ? in_place.size() : ws.size());
    (still ? any_in_place : any_moving) = true;
  }
  // the distinct angular targets: those of the rows taken, sorted (np.unique)
  std::vector<double> uw;
  if (any_moving) uw.insert(uw.end(), ws.begin(), ws.end());
  if (any_in_place) uw.insert(uw.end(), in_place.begin(), in_place.end());
  const std::vector<double> uws = sorted_distinct(uw);
  const auto nv = static_cast<std::int64_t>(vs.size()), nw = static_cast<std::int64_t>(uws.size());
  if (m > cap[0] || nv > cap[1] || nw > cap[2]) return -1;
  double* v = f + fo[0];
  double* w = f + fo[1];
  std::int64_t* iv = n + io[0];
  std::int64_t* iw = n + io[1];
  double v_abs = 0.0, w_abs = 0.0;
  std::int64_t t = 0;
  for (std::int64_t i = 0; i < nv; ++i) {
    const std::vector<double>& row = std::fabs(vs[i]) < 1e-9 ? in_place : ws;
    for (const double wi : row) {
      v[t] = vs[i];
      w[t] = wi;
      iv[t] = i;
      iw[t] = std::lower_bound(uws.begin(), uws.end(), wi) - uws.begin();
      v_abs = t == 0 ? std::fabs(vs[i]) : np_max(v_abs, std::fabs(vs[i]));
      w_abs = t == 0 ? std::fabs(wi) : np_max(w_abs, std::fabs(wi));
      ++t;
    }
  }
  f[fo[12]] = vs[0];  // v_brake
  // the granularity rule and the tables (rollouts.build_rollouts)
  const double steps = py_max(v_abs * sim_time / lin_gran, w_abs * sim_time / ang_gran);
  if (!(steps - 1e-9 <= static_cast<double>(cap[3]))) return -1;
  const std::int64_t k = std::max(std::int64_t{1}, static_cast<std::int64_t>(std::ceil(steps - 1e-9)));
  if (k > cap[3]) return -1;
  double* times = f + fo[2];
  linspace(0.0, sim_time, k + 1, times);
  const double dt = sim_time / static_cast<double>(k);
  double* ds = f + fo[3];
  double* yaw = f + fo[4];
  double* cs = f + fo[5];
  std::vector<double> mid(static_cast<std::size_t>(nw * k));
  jackson_dwb_tables(nv, vs.data(), state[0], acc_x, dec_x, nw, uws.data(), state[1], acc_th,
                     dec_th, k, times, dt, state[4], ds, yaw, mid.data());
  for (std::int64_t i = 0; i < nw * k; ++i) {
    cs[i] = std::cos(mid[i]);
    cs[nw * k + i] = std::sin(mid[i]);
  }
  // Rollouts.coarse and Batch.of
  const std::int64_t blocks = (k + stride - 1) / stride;
  double* cx = f + fo[6];
  double* cy = f + fo[7];
  jackson_dwb_coarse(m, k, stride, iv, iw, ds, cs, nw, state[2], state[3], cx, cy, f + fo[8]);
  const Grid g{grid[0], grid[1], grid[2], rows, cols};
  double* yaw_end = f + fo[9];
  double* cos_end = f + fo[10];
  double* sin_end = f + fo[11];
  std::int64_t* end_cell = n + io[2];
  std::uint8_t* end_ok = b + bo[0];
  for (std::int64_t i = 0; i < m; ++i) {
    yaw_end[i] = yaw[iw[i] * (k + 1) + k];
    cos_end[i] = std::cos(yaw_end[i]);
    sin_end[i] = std::sin(yaw_end[i]);
    const double xe = cx[blocks * m + i], ye = cy[blocks * m + i];
    end_cell[i] = cell_index(xe, ye, g, end_ok + i);
    for (std::int64_t j = 0; j < nf; ++j)
      n[io[3] + j * m + i] = cell_index(xe + fd[j] * cos_end[i], ye + fd[j] * sin_end[i], g,
                                        b + bo[1] + j * m + i);
  }
  sizes[0] = m;
  sizes[1] = nv;
  sizes[2] = nw;
  sizes[3] = k;
  sizes[4] = blocks;
  return 0;
}

// ObstacleLayer.update (host/nav/costmap/layers.py) in one call: the n returns p (n, 2) seen
// from the sensor (sx, sy), their rays cleared to free_value as _clear_rays samples them
// (jackson_clear_rays), then the returns within range marked lethal and, with hit_xy and
// spread (rows x cols x 2, rows x cols; null without discs), each marked cell's centroid of
// its returns and their largest distance from it (np.unique, np.bincount and np.maximum.at's
// sums and maxima, in the returns' order). ranges: raytrace min and max, obstacle min and max
// [m]; grid: origin x, origin y, resolution. The marked returns, in order, go to q (n, 2);
// returns their count.
std::int64_t jackson_obstacle_update(std::int64_t n, const double* p, double sx, double sy,
                                     const double* ranges, const double* grid,
                                     std::int64_t rows, std::int64_t cols, std::uint8_t* costs,
                                     std::uint8_t free_value, std::uint8_t lethal,
                                     double* hit_xy, double* spread, double* q) {
  const double ox = grid[0], oy = grid[1], res = grid[2];
  std::vector<double> length(static_cast<std::size_t>(n));
  for (std::int64_t i = 0; i < n; ++i) length[i] = std::hypot(p[2 * i] - sx, p[2 * i + 1] - sy);
  // the rays (_clear_rays): nothing beyond the grid's farthest corner from the sensor
  const double far_x = np_max(std::fabs(ox - sx), std::fabs(ox + static_cast<double>(cols) * res - sx));
  const double far_y = np_max(std::fabs(oy - sy), std::fabs(oy + static_cast<double>(rows) * res - sy));
  const double reach = std::hypot(far_x, far_y);
  const double shortest = py_max(ranges[0], 1e-9), cap = py_min(ranges[1], reach);
  std::vector<double> ux, uy, stop;
  double longest = 0.0;
  const double step = 0.5 * res, inv = 1.0 / res, per = step * inv;
  for (std::int64_t i = 0; i < n; ++i) {
    if (!(length[i] >= shortest)) continue;
    const double end = np_min(length[i], cap);
    const double s = length[i] <= end ? end - res : end;
    const double c = per / length[i];
    ux.push_back((p[2 * i] - sx) * c);
    uy.push_back((p[2 * i + 1] - sy) * c);
    longest = stop.empty() ? s : np_max(longest, s);
    stop.push_back(s);
  }
  if (!stop.empty() && longest > 0.0)
    jackson_clear_rays(static_cast<std::int64_t>(stop.size()), ux.data(), uy.data(), stop.data(),
                       (sx - ox) * inv, (sy - oy) * inv, step, rows, cols, costs, free_value);
  // the marks, and the cells' discs
  const Grid g{ox, oy, res, rows, cols};
  std::vector<std::pair<std::int64_t, std::int64_t>> cells;  // (cell, mark)
  std::int64_t marked = 0;
  for (std::int64_t i = 0; i < n; ++i) {
    if (!(length[i] >= ranges[2] && length[i] <= ranges[3])) continue;
    std::uint8_t on_grid = 0;
    const std::int64_t cell = cell_index(p[2 * i], p[2 * i + 1], g, &on_grid);
    if (!on_grid) continue;
    costs[cell] = lethal;
    q[2 * marked] = p[2 * i];
    q[2 * marked + 1] = p[2 * i + 1];
    cells.emplace_back(cell, marked);
    ++marked;
  }
  if (hit_xy == nullptr || spread == nullptr || cells.empty()) return marked;
  std::stable_sort(cells.begin(), cells.end(),
                   [](const auto& a, const auto& b) { return a.first < b.first; });
  for (std::size_t a = 0; a < cells.size();) {
    std::size_t b = a;
    double sum_x = 0.0, sum_y = 0.0;
    for (; b < cells.size() && cells[b].first == cells[a].first; ++b) {
      sum_x += q[2 * cells[b].second];
      sum_y += q[2 * cells[b].second + 1];
    }
    const double count = static_cast<double>(b - a);
    const double cx = sum_x / count, cy = sum_y / count;
    double far = 0.0;
    for (std::size_t j = a; j < b; ++j) {
      const double h = std::hypot(q[2 * cells[j].second] - cx, q[2 * cells[j].second + 1] - cy);
      far = np_max(far, h);
    }
    const std::int64_t cell = cells[a].first;
    hit_xy[2 * cell] = cx;
    hit_xy[2 * cell + 1] = cy;
    spread[cell] = far;
    a = b;
  }
  return marked;
}

// dwb.core.path.plan_span and plan_cells in one call: the slice [span[0], span[1]) of the n
// path points (x, y) the planner works with from (px, py) (prune: how far behind and ahead,
// each capped at half the window), densified to the resolution (densify), and the cells of
// the densified slice from its first on a known cell (255: unknown; costs padded by a ring,
// (rows + 2) x (cols + 2)) to the last before it leaves them, written to out_rows and
// out_cols (room: cap). Writes span and reaches_end; returns the cells' count, 0 when no
// point of the slice is on a known cell, or minus the room needed when cap is short. numpy's
// operations in numpy's order.
std::int64_t jackson_dwb_plan_cells(std::int64_t n, const double* path, double px, double py,
                                    double prune, double forward_prune, const double* grid,
                                    std::int64_t rows, std::int64_t cols,
                                    const std::uint8_t* costs, std::int64_t cap,
                                    std::int64_t* span, std::int64_t* out_rows,
                                    std::int64_t* out_cols, std::uint8_t* reaches_end) {
  const double res = grid[2];
  const double half = 0.5 * static_cast<double>(std::max(rows, cols)) * res;
  // the span (plan_span): the point nearest the robot, back and forward from it
  std::vector<double> d(static_cast<std::size_t>(n));
  std::int64_t near = 0;
  for (std::int64_t i = 0; i < n; ++i) {
    d[i] = std::hypot(path[2 * i] - px, path[2 * i + 1] - py);
    if (d[i] < d[near]) near = i;
  }
  const double back = py_min(half, prune), ahead = py_min(half, forward_prune);
  std::int64_t begin = 0;
  for (std::int64_t i = near - 1; i >= 0; --i)
    if (d[i] >= back) {
      begin = i + 1;
      break;
    }
  std::int64_t end = n;
  for (std::int64_t i = near; i < n; ++i)
    if (d[i] > ahead) {
      end = i;
      break;
    }
  end = std::max(end, begin + 1);
  span[0] = begin;
  span[1] = end;
  // densify: each segment in ceil(length / res) steps (at least one), then the last point
  const std::int64_t m = end - begin;
  const double* q = path + 2 * begin;
  std::vector<std::int64_t> steps(static_cast<std::size_t>(std::max<std::int64_t>(m - 1, 0)));
  std::int64_t total = 1;
  for (std::int64_t i = 0; i + 1 < m; ++i) {
    const double sx = q[2 * (i + 1)] - q[2 * i], sy = q[2 * (i + 1) + 1] - q[2 * i + 1];
    steps[i] = std::max<std::int64_t>(1, to_int(std::ceil(std::hypot(sx, sy) / res)));
    total += steps[i];
  }
  if (total > cap) return -total;
  std::vector<double> dense(static_cast<std::size_t>(2 * total));
  std::int64_t at = 0;
  for (std::int64_t i = 0; i + 1 < m; ++i) {
    const double sx = q[2 * (i + 1)] - q[2 * i], sy = q[2 * (i + 1) + 1] - q[2 * i + 1];
    const double ni = static_cast<double>(steps[i]);
    for (std::int64_t j = 0; j < steps[i]; ++j, ++at) {
      const double frac = static_cast<double>(j) / ni;
      dense[2 * at] = q[2 * i] + frac * sx;
      dense[2 * at + 1] = q[2 * i + 1] + frac * sy;
    }
  }
  dense[2 * at] = q[2 * (m - 1)];
  dense[2 * at + 1] = q[2 * (m - 1) + 1];
  // the cells, from the first known one to the last before the path leaves them
  const Grid g{grid[0], grid[1], res, rows, cols};
  std::int64_t first = -1, count = 0;
  for (std::int64_t i = 0; i < total; ++i) {
    const std::int64_t c = to_int(std::floor((dense[2 * i] - g.origin_x) / res));
    const std::int64_t r = to_int(std::floor((dense[2 * i + 1] - g.origin_y) / res));
    const bool known = r >= 0 && r < rows && c >= 0 && c < cols && costs[(r + 1) * (cols + 2) + c + 1] != 255;
    if (first < 0) {
      if (!known) continue;
      first = i;
    } else if (!known) {
      break;
    }
    out_rows[count] = r;
    out_cols[count] = c;
    ++count;
  }
  const std::int64_t last = first + count - 1;
  // np.allclose(dense[-1], path[-1]): |a - b| <= 1e-8 + 1e-5 |b| for x and y
  const double* tail = path + 2 * (n - 1);
  const double* dl = dense.data() + 2 * (total - 1);
  const bool close = std::fabs(dl[0] - tail[0]) <= 1e-8 + 1e-5 * std::fabs(tail[0]) &&
                     std::fabs(dl[1] - tail[1]) <= 1e-8 + 1e-5 * std::fabs(tail[1]);
  *reaches_end = first >= 0 && last == total - 1 && close;
  return count;
}

// Rollouts.trajectory: one roll-out's every pose, (k + 1) x 3 rows of (x, y, yaw), from its
// ramps' rows (ds, cos, sin: k; yaw: k + 1): the start as given, then the running sums of its
// steps plus the start, as Rollouts.full sums them.
void jackson_dwb_trajectory(std::int64_t k, const double* ds, const double* c, const double* s,
                            const double* yaw, double x0, double y0, double* out) {
  out[0] = x0;
  out[1] = y0;
  out[2] = yaw[0];
  double ax = 0.0, ay = 0.0;
  for (std::int64_t j = 0; j < k; ++j) {
    const double sx = ds[j] * c[j], sy = ds[j] * s[j];
    ax = j == 0 ? sx : ax + sx;
    ay = j == 0 ? sy : ay + sy;
    double* row = out + 3 * (j + 1);
    row[0] = ax + x0;
    row[1] = ay + y0;
    row[2] = yaw[j + 1];
  }
}

// FootprintChecker._index_obstacles, first half: the n lethal cells of a rows x cols grid
// (row-major, as np.nonzero finds them) as discs: a cell the obstacle layer marked lethal and
// the static layer did not is its returns' disc (hit_xy, spread), any other its centre's with
// radius res / sqrt 2. Writes the centres xy (n, 2), radii r, flat cells, and bounds[0, 1]:
// the largest reach of a disc beyond its cell centre (off + sqrt 2 r) and the largest
// shortfall (off - r), 0 without discs. grid: origin x, origin y, resolution.
void jackson_obstacle_discs(std::int64_t rows, std::int64_t cols, const std::uint8_t* lethal,
                            const std::uint8_t* obstacle, const std::uint8_t* stat,
                            const double* hit_xy, const double* spread, const double* grid,
                            std::uint8_t lethal_cost, double* xy, double* r, std::int64_t* cells,
                            double* bounds) {
  const double ox = grid[0], oy = grid[1], res = grid[2];
  const double cell_r = res / std::sqrt(2.0), sqrt2 = std::sqrt(2.0);
  double reach = 0.0, shortfall = 0.0;
  std::int64_t n = 0;
  for (std::int64_t i = 0; i < rows * cols; ++i) {
    if (!lethal[i]) continue;
    const double cx = ox + (static_cast<double>(i % cols) + 0.5) * res;
    const double cy = oy + (static_cast<double>(i / cols) + 0.5) * res;
    double px = cx, py = cy, radius = cell_r;
    if (obstacle[i] == lethal_cost && stat[i] != lethal_cost) {
      px = hit_xy[2 * i];
      py = hit_xy[2 * i + 1];
      radius = spread[i];
    }
    xy[2 * n] = px;
    xy[2 * n + 1] = py;
    r[n] = radius;
    cells[n] = i;
    const double off = std::hypot(px - cx, py - cy);
    const double far = off + sqrt2 * radius, near = off - radius;
    reach = n == 0 ? far : np_max(reach, far);
    shortfall = n == 0 ? near : np_max(shortfall, near);
    ++n;
  }
  bounds[0] = reach;
  bounds[1] = shortfall;
}

// FootprintChecker's second half: the obstacle ids over the grid padded by k cells (-1 where
// none; the n discs' cells), and each cell's class from the distance to the nearest lethal
// cell centre (near: <= near_m; deep: < deep_m) and the costs (lethal or unknown: blocked),
// over the grid padded by one blocked ring.
void jackson_obstacle_classes(std::int64_t rows, std::int64_t cols, std::int64_t n,
                              const std::int64_t* cells, std::int64_t k, std::int32_t* ids,
                              const double* dist, const std::uint8_t* costs,
                              std::uint8_t lethal_cost, double near_m, double deep_m,
                              std::uint8_t* cls) {
  const std::int64_t pc = cols + 2 * k;
  std::fill(ids, ids + (rows + 2 * k) * pc, -1);
  for (std::int64_t j = 0; j < n; ++j)
    ids[(cells[j] / cols + k) * pc + cells[j] % cols + k] = static_cast<std::int32_t>(j);
  const std::int64_t rc = cols + 2;
  std::fill(cls, cls + (rows + 2) * rc, kBlocked);
  for (std::int64_t i = 0; i < rows * cols; ++i) {
    std::uint8_t c = dist[i] <= near_m ? kNear : kClear;
    if (dist[i] < deep_m) c = kDeep;
    if (costs[i] >= lethal_cost) c = kBlocked;
    cls[(i / cols + 1) * rc + i % cols + 1] = c;
  }
}

// FootprintChecker._escape for a start pose (x, y, yaw) whose cell is near or deep: for each of
// m margins, the obstacles the start overlaps grown by it (allowed) and, when it overlaps any,
// its clearance less 1e-9 (floor_m; -inf when none): jackson_footprint_hits with the clearance,
// each distinct margin once.
void jackson_escape(std::int64_t m, const double* margin, double x, double y, double yaw,
                    const std::int32_t* ids, std::int64_t padded_rows, std::int64_t padded_cols,
                    std::int64_t k, const std::int64_t* offsets, std::int64_t n_offsets,
                    const double* obstacle_xy, const double* obstacle_r, const double* grid,
                    const double* robot, std::int64_t* allowed, double* floor_m) {
  const Obstacles o{ids,     padded_rows * padded_cols, padded_rows, padded_cols, k,
                    offsets, n_offsets,                 obstacle_xy, obstacle_r};
  const Grid g{grid[0], grid[1], grid[2], 0, 0};
  const Robot rb{robot[0], robot[1], robot[2], robot[3], robot[4], robot[5]};
  Candidates near(o);
  std::vector<double> seen_margin;
  std::vector<std::int64_t> seen_count;
  std::vector<double> seen_clear;
  for (std::int64_t t = 0; t < m; ++t) {
    std::size_t j = 0;
    while (j < seen_margin.size() && !(seen_margin[j] == margin[t])) ++j;
    if (j == seen_margin.size()) {
      double clear = 0.0;
      seen_count.push_back(hits_at(o, near, g, rb, x, y, yaw, margin[t], true, false, &clear));
      seen_clear.push_back(clear);
      seen_margin.push_back(margin[t]);
    }
    allowed[t] = seen_count[j];
    floor_m[t] = seen_count[j] > 0 ? seen_clear[j] - 1e-9
                                   : -std::numeric_limits<double>::infinity();
  }
}

// numpy's pairwise summation of n doubles (its add reduction along a contiguous axis:
// eight accumulators over blocks of up to 128, halves split on a multiple of 8 above).
static double pairwise_sum(const double* a, std::int64_t n) {
  if (n < 8) {
    double res = 0.0;
    for (std::int64_t i = 0; i < n; ++i) res += a[i];
    return res;
  }
  if (n <= 128) {
    double r[8];
    for (int j = 0; j < 8; ++j) r[j] = a[j];
    std::int64_t i = 8;
    for (; i < n - (n % 8); i += 8)
      for (int j = 0; j < 8; ++j) r[j] += a[i + j];
    double res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]));
    for (; i < n; ++i) res += a[i];
    return res;
  }
  std::int64_t n2 = n / 2;
  n2 -= n2 % 8;
  return pairwise_sum(a, n2) + pairwise_sum(a + n2, n - n2);
}

// likelihood_field_model (host/nav/amcl/sensor_model.py) with its beams' scores cubed per cell
// of the padded field beforehand (cubes, numpy's exp): each of n particles' b beam end points
// carried into the map (cos and sin of its heading numpy's), its padded cell
// (LikelihoodField.distance_xy), the cubes summed in numpy's pairwise order, plus one.
// grid: origin x, origin y, 1 / resolution.
void jackson_amcl_weigh(std::int64_t n, const double* particles, const double* cos_yaw,
                        const double* sin_yaw, std::int64_t b, const double* beams,
                        const double* grid, std::int64_t rows_p, std::int64_t cols_p,
                        const double* cubes, double* likelihood) {
  std::vector<double> q(static_cast<std::size_t>(b));
  const double top_col = static_cast<double>(cols_p) - 2.0;
  const double top_row = static_cast<double>(rows_p) - 2.0;
  const double cols_d = static_cast<double>(cols_p);
  const double shift = cols_d + 1.0;
  for (std::int64_t i = 0; i < n; ++i) {
    const double x = particles[3 * i], y = particles[3 * i + 1];
    const double c = cos_yaw[i], s = sin_yaw[i];
    for (std::int64_t j = 0; j < b; ++j) {
      const double bx = beams[2 * j], by = beams[2 * j + 1];
      const double mx = (x + c * bx) - s * by;
      const double my = (y + s * bx) + c * by;
      // np.fmax(np.fmin(v, top), -1.0): NaN reads top, then a number; the sign of a zero
      // cannot change the index
      double col = std::floor((mx - grid[0]) * grid[2]);
      col = col < top_col ? col : top_col;
      col = col > -1.0 ? col : -1.0;
      double row = std::floor((my - grid[1]) * grid[2]);
      row = row < top_row ? row : top_row;
      row = row > -1.0 ? row : -1.0;
      const auto cell = static_cast<std::int64_t>((row * cols_d + col) + shift);
      q[static_cast<std::size_t>(j)] = cubes[cell];
    }
    likelihood[i] = 1.0 + pairwise_sum(q.data(), b);
  }
}

// Costmap.cost_at (GridCells.padded_index, then np.take): the master cost at n map-frame points
// (x, y) from the costs padded by one ring (rows + 2) x (cols + 2), a point off the grid on the
// ring. The index by numpy's operations: (v - origin) / resolution + 1, clipped into [0, size +
// 1], truncated. Returns 0, or -1 at a NaN (numpy's path then answers as it does).
std::int64_t jackson_cost_at(std::int64_t n, const double* x, const double* y, double origin_x,
                             double origin_y, double resolution, std::int64_t rows,
                             std::int64_t cols, const std::uint8_t* costs, std::uint8_t* out) {
  const double top_c = static_cast<double>(cols) + 1.0;
  const double top_r = static_cast<double>(rows) + 1.0;
  for (std::int64_t i = 0; i < n; ++i) {
    const double fx = (x[i] - origin_x) / resolution + 1.0;
    const double fy = (y[i] - origin_y) / resolution + 1.0;
    if (fx != fx || fy != fy) return -1;
    const auto col = static_cast<std::int64_t>(std::min(std::max(fx, 0.0), top_c));
    const auto row = static_cast<std::int64_t>(std::min(std::max(fy, 0.0), top_r));
    out[i] = costs[row * (cols + 2) + col];
  }
  return 0;
}

// GlobalPlanning.path_blocked's test, after prune_path: of the n path points (x, y), those from
// the one nearest (px, py) on (np.argmin of np.hypot: the first of equals) and farther than
// ``near`` from it, whether one lies on an inscribed or lethal cell of either costmap (as
// jackson_cost_at reads them; m = 2 costmaps: grids[5 k ..] = origin x, origin y, resolution,
// rows, cols, costs[k] padded). Returns 1 (blocked), 0, or -1 at a NaN (numpy's path then
// answers).
std::int64_t jackson_path_blocked(std::int64_t n, const double* path, double px, double py,
                                  double near, const double* grids, const std::uint8_t* costs0,
                                  const std::uint8_t* costs1, std::uint8_t inscribed,
                                  std::uint8_t lethal) {
  if (n == 0) return 0;
  std::int64_t first = 0;
  double best = 0.0;
  for (std::int64_t i = 0; i < n; ++i) {
    const double d = std::hypot(path[2 * i] - px, path[2 * i + 1] - py);
    if (d != d) return -1;
    if (i == 0 || d < best) {
      best = d;
      first = i;
    }
  }
  const std::uint8_t* costs[2] = {costs0, costs1};
  for (int k = 0; k < 2; ++k) {
    const double* g = grids + 5 * k;
    const auto rows = static_cast<std::int64_t>(g[3]), cols = static_cast<std::int64_t>(g[4]);
    for (std::int64_t i = first; i < n; ++i) {
      const double x = path[2 * i], y = path[2 * i + 1];
      if (!(std::hypot(x - px, y - py) > near)) continue;
      std::uint8_t cost = 0;
      if (jackson_cost_at(1, &x, &y, g[0], g[1], g[2], rows, cols, costs[k], &cost) != 0)
        return -1;
      if (cost == inscribed || cost == lethal) return 1;
    }
  }
  return 0;
}

}  // extern "C"
