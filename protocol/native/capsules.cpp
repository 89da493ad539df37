// EXPRESS_SCAN capsule streams decoded in one call: jackson.protocol.rplidar.CapsuleDecoder's
// feed, compiled (loaded with ctypes by jackson.protocol.native).
//
// The same walk over the bytes as the interpreted decoder (a capsule is recognised by its
// sync nibbles and checksum, a byte that starts none is skipped and counted), the same
// bookkeeping of the held capsule and the S bit, and the same fixed-point arithmetic as
// Slamtec's SDK for every sample: integers throughout but for the ultra capsules' parallax,
// whose radian-to-degree conversion is one IEEE double division as numpy's. The samples are
// the interpreted decoder's bit for bit (tests/protocol/test_rplidar_native.py).
//
// Built by tools/build_compiled.py with -ffp-contract=off.

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <vector>

namespace {

constexpr int64_t kSync1 = 0xA;
constexpr int64_t kSync2 = 0x5;
constexpr int64_t kStartBit = 0x8000;
constexpr int64_t kHeader = 4;
constexpr int64_t kAngleQ6Max = 0x7FFF;
constexpr int64_t kTurnQ6 = 360 * 64;
constexpr int64_t kTurnQ16 = int64_t{360} << 16;
constexpr int64_t kPredictNone = 0x1FF;

// the formats, by answer type
constexpr int kLegacy = 0x82;
constexpr int kUltra = 0x84;
constexpr int kDense = 0x85;

int64_t shl(int64_t v, int64_t n) { return v * (int64_t{1} << n); }  // numpy's << on int64

int64_t floor_shr(int64_t v, int n) {  // numpy's >> on int64: arithmetic (floor)
    return v >= 0 ? v >> n : -((-v - 1) >> n) - 1;
}

int64_t floor_div(int64_t a, int64_t b) {  // numpy's // for b > 0
    const int64_t q = a / b;
    return (a % b != 0 && a < 0) ? q - 1 : q;
}

int64_t floor_mod(int64_t a, int64_t b) { return a - floor_div(a, b) * b; }  // numpy's %, b > 0

int64_t u16(const uint8_t* p) { return int64_t{p[0]} | (int64_t{p[1]} << 8); }

int64_t u32(const uint8_t* p) {
    return int64_t{p[0]} | (int64_t{p[1]} << 8) | (int64_t{p[2]} << 16) | (int64_t{p[3]} << 24);
}

// a 12-bit variable-bit-scale code's distance [mm] and level
void varbitscale(int64_t c, int64_t* mm, int64_t* level) {
    if (c >= 3328) {
        *mm = (int64_t{1} << 14) + ((c - 3328) << 4);
        *level = 4;
    } else if (c >= 1792) {
        *mm = (int64_t{1} << 12) + ((c - 1792) << 3);
        *level = 3;
    } else if (c >= 1280) {
        *mm = (int64_t{1} << 11) + ((c - 1280) << 2);
        *level = 2;
    } else if (c >= 512) {
        *mm = (int64_t{1} << 9) + ((c - 512) << 1);
        *level = 1;
    } else {
        *mm = c;
        *level = 0;
    }
}

int64_t signed10(int64_t x) { return x >= 0x200 ? x - 0x400 : x; }

// ultra_angle_offset_q16: the parallax subtracted from an ultra sample's angle
int64_t ultra_offset_q16(int64_t q) {
    int64_t rad_q16;
    if (q >= 200) {
        int64_t k = 98361 / (q > 1 ? q : 1);  // q > 0 here: floor and C's division agree
        rad_q16 = 9150 - shl(k, 6) - (k * k * k) / 98304;
    } else {
        rad_q16 = 8578;
    }
    return static_cast<int64_t>(static_cast<double>(rad_q16 * 180) / 3.14159265);
}

int64_t wrap_q6(int64_t a) {
    if (a < 0) a += kTurnQ6;
    if (a >= kTurnQ6) a -= kTurnQ6;
    return a;
}

// one capsule's samples, given the capsule after it
void decode_pair(int fmt, int64_t samples, const uint8_t* held, const uint8_t* follow,
                 uint8_t* last_sync, uint8_t* start, int64_t* angle_q6, int64_t* dist_q2) {
    const int64_t first_q8 = (u16(held + 2) & kAngleQ6Max) << 2;
    const int64_t next_q8 = (u16(follow + 2) & kAngleQ6Max) << 2;
    const int64_t diff_q8 = next_q8 - first_q8 + (first_q8 > next_q8 ? (int64_t{360} << 8) : 0);
    int64_t inc_q16;
    if (fmt == kLegacy) {
        inc_q16 = shl(diff_q8, 3);
    } else if (fmt == kUltra) {
        inc_q16 = floor_div(shl(diff_q8, 3), 3);  // negative past a 15-bit start angle
    } else {
        inc_q16 = floor_div(shl(diff_q8, 8), 40);
    }
    const uint8_t* body = held + kHeader;
    for (int64_t k = 0; k < samples; ++k) {
        const int64_t raw_q16 = shl(first_q8, 8) + k * inc_q16;
        int64_t dist = 0;
        int64_t angle = 0;
        if (fmt == kLegacy) {
            const uint8_t* cab = body + 5 * (k / 2);
            const int64_t w = (k % 2 == 0) ? u16(cab) : u16(cab + 2);
            dist = w & 0xFFFC;
            const int64_t dtheta_q3 =
                (k % 2 == 0) ? ((cab[4] & 0xF) | ((w & 3) << 4)) : ((cab[4] >> 4) | ((w & 3) << 4));
            angle = floor_shr(raw_q16 - shl(dtheta_q3, 13), 10);
        } else if (fmt == kUltra) {
            const int64_t j = k / 3;
            const int64_t word = u32(body + 4 * j);
            const int64_t next_word = (j + 1 < samples / 3) ? u32(body + 4 * (j + 1))
                                                            : u32(follow + kHeader);
            int64_t this_mm, this_lvl, next_mm, next_lvl;
            varbitscale(word & 0xFFF, &this_mm, &this_lvl);
            varbitscale(next_word & 0xFFF, &next_mm, &next_lvl);
            int64_t d;
            switch (k % 3) {
                case 0:
                    d = this_mm;
                    break;
                case 1: {
                    const bool borrow = this_mm == 0 && next_mm != 0;
                    const int64_t base = borrow ? next_mm : this_mm;
                    const int64_t lvl = borrow ? next_lvl : this_lvl;
                    const int64_t p = signed10((word >> 12) & 0x3FF);
                    d = (p == -512 || p == kPredictNone) ? 0 : shl(p, lvl) + base;
                    break;
                }
                default: {
                    const int64_t p = signed10((word >> 22) & 0x3FF);
                    d = (p == -512 || p == kPredictNone) ? 0 : shl(p, next_lvl) + next_mm;
                    break;
                }
            }
            dist = shl(d, 2);
            angle = floor_shr(raw_q16 - ultra_offset_q16(dist), 10);
        } else {
            dist = shl(u16(body + 2 * k), 2);
            angle = floor_shr(raw_q16, 10);
        }
        bool sync;
        if (fmt == kDense) {  // a sync flag is raised once per turn, along the stream
            const int64_t wrapped = floor_mod(raw_q16 + inc_q16, kTurnQ16);
            sync = wrapped < 2 * inc_q16 && !*last_sync;
            *last_sync = sync ? 1 : 0;
        } else {  // the last sample's next angle: the next capsule's own start
            const int64_t nxt = (k + 1 < samples) ? raw_q16 + inc_q16 : shl(first_q8 + diff_q8, 8);
            sync = raw_q16 < kTurnQ16 && nxt >= kTurnQ16;
        }
        start[k] = sync ? 1 : 0;
        angle_q6[k] = wrap_q6(angle);
        dist_q2[k] = dist;
    }
}

// numpy's floor modulo of doubles, b > 0: fmod, moved into [0, b), a zero remainder +0
double np_fmod_floor(double a, double b) {
    double mod = std::fmod(a, b);
    if (mod != 0.0) {
        if ((b < 0) != (mod < 0)) mod += b;
    } else {
        mod = std::copysign(0.0, b);
    }
    return mod;
}

// varbitscale_encode: the 12-bit code nearest to a distance [mm]
int64_t varbitscale_code(int64_t d) {
    int64_t code = d;
    if (d >= (int64_t{1} << 14)) {
        code = 3328 + ((d - (int64_t{1} << 14) + (int64_t{1} << 3)) >> 4);
    } else if (d >= (int64_t{1} << 12)) {
        code = 1792 + ((d - (int64_t{1} << 12) + (int64_t{1} << 2)) >> 3);
    } else if (d >= (int64_t{1} << 11)) {
        code = 1280 + ((d - (int64_t{1} << 11) + (int64_t{1} << 1)) >> 2);
    } else if (d >= (int64_t{1} << 9)) {
        code = 512 + ((d - (int64_t{1} << 9) + 1) >> 1);
    }
    return code < 0 ? 0 : (code > 0xFFF ? 0xFFF : code);
}

// The emulator's beams read at headings (sim/rplidar_ranges.py's ranges_at): linear between
// the two beams around each heading unless they differ by more than edge_fraction of the
// nearer or one has no return, then the nearer's. ``r`` holds the beams' ranges with no
// return as inf.
struct Beams {
    int64_t beams;
    double inc, angle_min, gap, edge_fraction;
    const double* r;

    // _beam_position: the heading's counter-clockwise angle from the first beam, and the
    // beam at or before it
    int64_t position(double heading_deg, double* alpha) const {
        *alpha = np_fmod_floor(-(heading_deg * (M_PI / 180.0)) - angle_min, 2.0 * M_PI);
        const int64_t i0 = static_cast<int64_t>(std::floor(*alpha / inc));
        return i0 > beams - 1 ? beams - 1 : i0;
    }

    double at(double heading_deg) const {
        double alpha;
        const int64_t i0 = position(heading_deg, &alpha);
        const double width = i0 == beams - 1 ? gap : inc;
        double f = (alpha - static_cast<double>(i0) * inc) / width;
        f = std::min(std::max(f, 0.0), 1.0);
        const double r0 = r[i0], r1 = r[(i0 + 1) % beams];
        const bool smooth = std::isfinite(r0) && std::isfinite(r1) &&
                            std::fabs(r1 - r0) <= edge_fraction * std::min(r0, r1);
        if (smooth) return r0 + f * (r1 - r0);
        return f < 0.5 ? r0 : r1;
    }
};

// _millimetres: a range [m] as whole millimetres for the wire, 0 for no return
int64_t millimetres(double range_m, double top) {
    if (!(std::isfinite(range_m) && range_m > 0.0)) return 0;
    const double mm = std::nearbyint(range_m * 1000.0);
    return static_cast<int64_t>(std::min(std::max(mm, 1.0), top));
}

}  // namespace

extern "C" {

// CapsuleDecoder.feed over the buffer ``buf`` (``len`` bytes, capsules of ``n`` bytes with
// ``samples`` samples, answer type ``fmt``); ``held`` is the capsule held from before (or
// null). ``state`` in/out: [held is set, the dense format's last sync flag]. ``counts`` out:
// [bytes consumed, capsules, starts, malformed bytes, offset in ``buf`` of the capsule now
// held (-1: the one held before, or none)]. The samples of every capsule the next one
// completed go to ``start``, ``angle_q6`` and ``dist_q2`` (room for ``len / n * samples``).
// Returns the number of samples written.
int64_t jackson_capsules_feed(int64_t fmt, int64_t n, int64_t samples, const uint8_t* buf,
                              int64_t len, const uint8_t* held, uint8_t* state, int64_t* counts,
                              uint8_t* start, int64_t* angle_q6, int64_t* dist_q2) {
    const uint8_t* holding = state[0] ? held : nullptr;
    uint8_t last_sync = state[1];
    int64_t pos = 0;
    int64_t capsules = 0, starts = 0, malformed = 0, held_at = -1, out = 0;
    while (pos < len) {
        if ((buf[pos] >> 4) != kSync1 || (len - pos > 1 && (buf[pos + 1] >> 4) != kSync2)) {
            ++malformed;
            ++pos;
            continue;
        }
        if (len - pos < n) break;
        const uint8_t* c = buf + pos;
        uint8_t x = 0;
        for (int64_t i = 2; i < n; ++i) x ^= c[i];
        if (x != ((c[0] & 0xF) | ((c[1] & 0xF) << 4))) {
            ++malformed;
            ++pos;
            continue;
        }
        ++capsules;
        if (u16(c + 2) & kStartBit) {
            ++starts;
            holding = nullptr;
        }
        if (holding != nullptr) {
            decode_pair(static_cast<int>(fmt), samples, holding, c, &last_sync, start + out,
                        angle_q6 + out, dist_q2 + out);
            out += samples;
        }
        holding = c;
        held_at = pos;
        pos += n;
    }
    state[0] = holding != nullptr ? 1 : 0;
    state[1] = last_sync;
    counts[0] = pos;
    counts[1] = capsules;
    counts[2] = starts;
    counts[3] = malformed;
    counts[4] = held_at;
    return out;
}

// A turn's samples as the host's RevolutionAssembler hands them on: angles counter-clockwise
// wrapped to [-pi, pi) [rad], ranges [m] (no return or beyond ``cap_m``: inf), in order of
// angle (a stable sort; ``order`` out: the samples' order). The same IEEE operations as numpy's: -(double)q6 * q6_to_rad, then
// (a + pi) mod 2 pi - pi with numpy's floor modulo (fmod, moved into [0, 2 pi), a zero
// remainder +0).
void jackson_rplidar_turn(int64_t n, const int64_t* angle_q6, const int64_t* dist_q2,
                          double q6_to_rad, double q2_to_m, double cap_m, double pi,
                          double* angles_out, double* ranges_out, int64_t* order) {
    const double two_pi = 2.0 * pi;
    std::vector<double> a(static_cast<size_t>(n)), r(static_cast<size_t>(n));
    for (int64_t i = 0; i < n; ++i) {
        a[i] = np_fmod_floor(-static_cast<double>(angle_q6[i]) * q6_to_rad + pi, two_pi) - pi;
        const double range = static_cast<double>(dist_q2[i]) * q2_to_m;
        r[i] = (dist_q2[i] == 0 || range > cap_m) ? HUGE_VAL : range;
    }
    std::iota(order, order + n, int64_t{0});
    std::stable_sort(order, order + n, [&a](int64_t i, int64_t j) { return a[i] < a[j]; });
    for (int64_t i = 0; i < n; ++i) {
        angles_out[i] = a[order[i]];
        ranges_out[i] = r[order[i]];
    }
}

// The emulator's ultra samples (sim/rplidar_ranges.py's parallax_ranged): each sample
// at raw angle ``raw_deg`` ranged where a decoder will place it, its raw angle less the
// parallax offset of the distance it will decode (variable-bit-scale quantised), found by
// ``iterations`` steps from two starts: the offset ``start_deg`` and the offset of the nearest
// of the ``window`` beams from the one at heading raw + ``window_shift_deg`` on; the nearer
// distance that fits wins. A sample whose distance disagrees by more than ``edge_fraction``
// with the range where it decodes, from both starts, goes out as no return. ``ranges_m``: the
// revolution's ``beams`` ranges (inf, NaN or <= 0: no return). Writes the distances [mm] to
// ``out_mm``; returns how many samples with a return from the first start went out as none.
int64_t jackson_ultra_ranged(int64_t beams, double inc, double angle_min, double edge_fraction,
                             const double* ranges_m, int64_t n, const double* raw_deg,
                             int64_t iterations, double start_deg, double window_shift_deg,
                             int64_t window, int64_t* out_mm) {
    std::vector<double> r(static_cast<size_t>(beams));
    for (int64_t i = 0; i < beams; ++i) {
        const double x = ranges_m[i];
        r[i] = (std::isfinite(x) && x > 0.0) ? x : HUGE_VAL;
    }
    // the beam after the last, one turn on
    const double gap = std::max(2.0 * M_PI - static_cast<double>(beams - 1) * inc, inc);
    const Beams b{beams, inc, angle_min, gap, edge_fraction, r.data()};
    // _decoded_heading: where a decoder puts a sample of raw angle ``raw`` sent with ``mm``
    const auto decoded_heading = [](double raw, int64_t mm) {
        int64_t decoded, level;
        varbitscale(varbitscale_code(mm), &decoded, &level);
        return raw - static_cast<double>(ultra_offset_q16(4 * decoded)) / 65536.0;
    };
    // _parallax_search: the distance from a start heading, and whether it fits
    const auto search = [&](double raw, double heading, int64_t* mm) {
        *mm = 0;
        for (int64_t it = 0; it < iterations; ++it) {
            *mm = millimetres(b.at(heading), 65535.0);
            heading = decoded_heading(raw, *mm);
        }
        const int64_t there = millimetres(b.at(heading), 65535.0);
        const int64_t diff = there > *mm ? there - *mm : *mm - there;
        return static_cast<double>(diff) <=
               edge_fraction * static_cast<double>(std::min(there, *mm));
    };
    // each beam's nearest range over the window from it on (van Herk's running minima: the
    // minima of blocks of ``window`` from their start and from their end)
    const int64_t len = beams + window - 1;
    std::vector<double> ext(static_cast<size_t>(len)), ahead(ext.size()), behind(ext.size());
    for (int64_t i = 0; i < len; ++i) ext[i] = r[i % beams];
    for (int64_t i = 0; i < len; ++i)
        ahead[i] = i % window == 0 ? ext[i] : std::min(ahead[i - 1], ext[i]);
    for (int64_t i = len - 1; i >= 0; --i)
        behind[i] = (i % window == window - 1 || i == len - 1) ? ext[i]
                                                               : std::min(behind[i + 1], ext[i]);
    std::vector<double> nearest_from(static_cast<size_t>(beams));
    for (int64_t j = 0; j < beams; ++j)
        nearest_from[j] = std::min(behind[j], ahead[j + window - 1]);
    int64_t dropouts = 0;
    for (int64_t k = 0; k < n; ++k) {
        const double raw = raw_deg[k];
        int64_t far_mm, near_mm;
        const bool far_fits = search(raw, raw - start_deg, &far_mm);
        // the nearest beam the laser's line can cross (_window_beams from this one on)
        double alpha;
        const int64_t first = b.position(raw + window_shift_deg, &alpha);
        const int64_t nearest_mm = millimetres(nearest_from[first], 65535.0);
        const int64_t far = far_fits ? far_mm : 0;
        bool near = false;
        if (far == 0 || nearest_mm < far) {  // else nothing the line crosses is nearer
            const bool near_fits = search(raw, decoded_heading(raw, nearest_mm), &near_mm);
            near = near_fits && near_mm > 0 && (far == 0 || near_mm < far);
        }
        out_mm[k] = near ? near_mm : far;
        if (out_mm[k] == 0 && !far_fits && far_mm > 0) ++dropouts;
    }
    return dropouts;
}

// Ultra capsules (encode_ultra_cabins and ultra_capsule_of_cabins of express.py): capsule c
// from the 97 distances [mm] d[97 c .. 97 c + 96] (its 96 and the next one's first, >= 0) and
// its start angle start_q6[c] (0..0x7FFF), the S bit on the first capsule when ``start``; 132
// bytes each to ``out``. Returns how many samples with a distance decode as no return (a jump
// the prediction cannot reach).
int64_t jackson_ultra_capsules(int64_t count, const int64_t* d, const int64_t* start_q6,
                               uint8_t start, uint8_t* out) {
    int64_t dropouts = 0;
    for (int64_t c = 0; c < count; ++c) {
        const int64_t* dc = d + 97 * c;
        int64_t mm[33], lvl[33], code[33];
        for (int j = 0; j < 33; ++j) {
            code[j] = varbitscale_code(dc[3 * j]);
            varbitscale(code[j], &mm[j], &lvl[j]);
        }
        uint8_t* cap = out + 132 * c;
        const int64_t word = start_q6[c] | ((c == 0 && start) ? kStartBit : 0);
        cap[2] = static_cast<uint8_t>(word & 0xFF);
        cap[3] = static_cast<uint8_t>(word >> 8);
        for (int j = 0; j < 32; ++j) {
            const bool borrow = mm[j] == 0 && mm[j + 1] != 0;
            int64_t p[2];
            const int64_t base[2] = {borrow ? mm[j + 1] : mm[j], mm[j + 1]};
            const int64_t level[2] = {borrow ? lvl[j + 1] : lvl[j], lvl[j + 1]};
            if (mm[j] == 0 && dc[3 * j] > 0) ++dropouts;
            for (int k = 0; k < 2; ++k) {  // _predict
                const int64_t target = dc[3 * j + 1 + k];
                const int64_t step = int64_t{1} << level[k];
                const int64_t q = floor_div(target - base[k] + (step >> 1), step);
                const bool ok = target > 0 && q >= -511 && q <= 510;
                p[k] = ok ? q : kPredictNone;
                const int64_t got = ok ? base[k] + q * step : 0;  // what a decoder gets back
                if (got == 0 && target > 0) ++dropouts;
            }
            const uint32_t w = static_cast<uint32_t>(code[j]) |
                               (static_cast<uint32_t>(p[0] & 0x3FF) << 12) |
                               (static_cast<uint32_t>(p[1] & 0x3FF) << 22);
            uint8_t* at = cap + 4 + 4 * j;
            at[0] = static_cast<uint8_t>(w);
            at[1] = static_cast<uint8_t>(w >> 8);
            at[2] = static_cast<uint8_t>(w >> 16);
            at[3] = static_cast<uint8_t>(w >> 24);
        }
        uint8_t x = 0;
        for (int i = 2; i < 132; ++i) x ^= cap[i];
        cap[0] = static_cast<uint8_t>((kSync1 << 4) | (x & 0xF));
        cap[1] = static_cast<uint8_t>((kSync2 << 4) | (x >> 4));
    }
    return dropouts;
}

}  // extern "C"
