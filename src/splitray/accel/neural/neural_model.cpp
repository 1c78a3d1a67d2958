#include "splitray/accel/neural/neural_model.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>

#if defined(__AVX512F__) || (defined(__AVX2__) && defined(__FMA__))
#include <immintrin.h>
#endif

#include "splitray/core/errors.hpp"
#include "splitray/core/image.hpp"

namespace splitray {

namespace {

constexpr char kMagic[16] = {'S', 'P', 'L', 'I', 'T', 'R', 'A', 'Y',
                             '-', 'N', 'E', 'U', 'R', 'A', 'L', '1'};
constexpr std::uint32_t kMaxCount = 4096;
constexpr std::uint32_t kMaxMetadata = 1u << 24;  // 16 MiB of JSON is already absurd

// Reads little-endian fields from the file's bytes; every failure names the file.
class Reader {
 public:
  Reader(const std::string& path, std::string bytes) : path_(path), bytes_(std::move(bytes)) {}

  [[noreturn]] void fail(const std::string& problem) const {
    throw Error(path_, "not a valid neural model: " + problem);
  }

  void take(void* out, std::size_t n, const char* what) {
    if (bytes_.size() - pos_ < n) fail(std::string("truncated while reading ") + what);
    std::memcpy(out, bytes_.data() + pos_, n);
    pos_ += n;
  }

  std::uint32_t u32(const char* what) {
    unsigned char b[4];
    take(b, 4, what);
    return std::uint32_t{b[0]} | std::uint32_t{b[1]} << 8 | std::uint32_t{b[2]} << 16 |
           std::uint32_t{b[3]} << 24;
  }

  std::uint32_t count(const char* what, std::uint32_t lo = 0, std::uint32_t hi = kMaxCount) {
    const std::uint32_t v = u32(what);
    if (v < lo || v > hi)
      fail(std::string(what) + " = " + std::to_string(v) + " is outside [" + std::to_string(lo) +
           ", " + std::to_string(hi) + "]");
    return v;
  }

  void floats(std::vector<float>& out, std::size_t n, const char* what) {
    if ((bytes_.size() - pos_) / 4 < n) fail(std::string("truncated while reading ") + what);
    out.resize(n);
    for (std::size_t i = 0; i < n; ++i) {
      const std::uint32_t bits = u32(what);
      float f;
      std::memcpy(&f, &bits, 4);
      if (!std::isfinite(f)) fail(std::string("non-finite number in ") + what);
      out[i] = f;
    }
  }

  std::string text(std::size_t n, const char* what) {
    if (bytes_.size() - pos_ < n) fail(std::string("truncated while reading ") + what);
    std::string s = bytes_.substr(pos_, n);
    pos_ += n;
    return s;
  }

  bool at_end() const { return pos_ == bytes_.size(); }
  std::size_t remaining() const { return bytes_.size() - pos_; }

 private:
  std::string path_;
  std::string bytes_;
  std::size_t pos_ = 0;
};

// Reads `count` layers; `in` is the input width the first must have; returns the last out.
std::vector<DenseLayer> read_layers(Reader& r, std::uint32_t& in, const std::string& where) {
  const std::uint32_t n = r.count("layer count", 1);
  std::vector<DenseLayer> layers(n);
  for (std::uint32_t i = 0; i < n; ++i) {
    DenseLayer& l = layers[i];
    const std::uint32_t lin = r.count("layer in", 1);
    const std::uint32_t lout = r.count("layer out", 1);
    const std::uint32_t act = r.count("activation", 0, 1);
    if (lin != in)
      r.fail(where + " layer " + std::to_string(i) + " has in = " + std::to_string(lin) +
             " but its input has width " + std::to_string(in));
    l.in = static_cast<int>(lin);
    l.out = static_cast<int>(lout);
    l.activation = static_cast<int>(act);
    r.floats(l.weight, std::size_t{lin} * lout, "weights");
    r.floats(l.bias, lout, "biases");
    in = lout;
  }
  return layers;
}

void put_u32(std::string& out, std::uint32_t v) {
  for (int i = 0; i < 4; ++i) out.push_back(static_cast<char>((v >> (8 * i)) & 0xff));
}

void put_layers(std::string& out, const std::vector<DenseLayer>& layers) {
  put_u32(out, static_cast<std::uint32_t>(layers.size()));
  for (const DenseLayer& l : layers) {
    put_u32(out, static_cast<std::uint32_t>(l.in));
    put_u32(out, static_cast<std::uint32_t>(l.out));
    put_u32(out, static_cast<std::uint32_t>(l.activation));
    for (float f : l.weight) {
      std::uint32_t bits;
      std::memcpy(&bits, &f, 4);
      put_u32(out, bits);
    }
    for (float f : l.bias) {
      std::uint32_t bits;
      std::memcpy(&bits, &f, 4);
      put_u32(out, bits);
    }
  }
}

// The writer refuses what the reader would refuse, so a written file always reads back.
void check_layers(const std::vector<DenseLayer>& layers, int in, const std::string& path,
                  const std::string& where) {
  if (layers.empty() || layers.size() > kMaxCount) throw Error(path, where + ": bad layer count");
  for (std::size_t i = 0; i < layers.size(); ++i) {
    const DenseLayer& l = layers[i];
    const std::string name = where + " layer " + std::to_string(i);
    if (l.in != in || l.out < 1 || l.out > static_cast<int>(kMaxCount))
      throw Error(path, name + ": shapes do not chain");
    if (l.activation < 0 || l.activation > 1) throw Error(path, name + ": unknown activation");
    if (l.weight.size() != static_cast<std::size_t>(l.in) * l.out ||
        l.bias.size() != static_cast<std::size_t>(l.out))
      throw Error(path, name + ": weight or bias size does not match in × out");
    for (float f : l.weight)
      if (!std::isfinite(f)) throw Error(path, name + ": non-finite weight");
    for (float f : l.bias)
      if (!std::isfinite(f)) throw Error(path, name + ": non-finite bias");
    in = l.out;
  }
}

}  // namespace

NeuralModel read_neural_model(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot open the neural model file");
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw Error(path, "cannot read the neural model file");
  Reader r(path, std::move(bytes));

  char magic[16];
  r.take(magic, 16, "the magic");
  if (std::memcmp(magic, kMagic, 16) != 0) r.fail("wrong magic (expected SPLITRAY-NEURAL1)");

  NeuralModel m;
  m.cost = static_cast<NeuralCost>(r.count("cost", 0, 1));
  const std::uint32_t depth = r.count("depth", 1, 64);
  m.points = static_cast<int>(r.count("points", 1, 1u << 24));
  m.pooling = static_cast<NeuralPooling>(r.count("pooling", 0, 1));
  m.levels.resize(depth);
  for (std::uint32_t d = 0; d < depth; ++d) {
    const std::string level = "level " + std::to_string(d);
    std::uint32_t width = 1;
    m.levels[d].point_layers = read_layers(r, width, level + " point");
    m.levels[d].head_layers = read_layers(r, width, level + " head");
    if (width != 1)
      r.fail(level + ": the last head layer has out = " + std::to_string(width) + ", not 1");
  }
  const std::uint32_t meta = r.count("metadata length", 0, kMaxMetadata);
  m.metadata = r.text(meta, "the metadata");
  if (!r.at_end()) r.fail(std::to_string(r.remaining()) + " trailing bytes after the metadata");
  return m;
}

void write_neural_model(const NeuralModel& model, const std::string& path) {
  if (model.levels.empty() || model.levels.size() > 64)
    throw Error(path, "model depth must be 1..64");
  if (model.points < 1) throw Error(path, "model points must be positive");
  for (std::size_t d = 0; d < model.levels.size(); ++d) {
    const std::string level = "level " + std::to_string(d);
    const LevelEncoder& e = model.levels[d];
    check_layers(e.point_layers, 1, path, level + " point");
    check_layers(e.head_layers, e.point_layers.back().out, path, level + " head");
    if (e.head_layers.back().out != 1)
      throw Error(path, level + ": the last head layer must have out = 1");
  }
  if (model.metadata.size() > kMaxMetadata) throw Error(path, "metadata too long");

  std::string out(kMagic, 16);
  put_u32(out, static_cast<std::uint32_t>(model.cost));
  put_u32(out, static_cast<std::uint32_t>(model.levels.size()));
  put_u32(out, static_cast<std::uint32_t>(model.points));
  put_u32(out, static_cast<std::uint32_t>(model.pooling));
  for (const LevelEncoder& e : model.levels) {
    put_layers(out, e.point_layers);
    put_layers(out, e.head_layers);
  }
  put_u32(out, static_cast<std::uint32_t>(model.metadata.size()));
  out += model.metadata;
  write_file_atomically(path, out);
}

namespace {

constexpr int kLanes = 16;  // activations and weights are padded to multiples of this width
constexpr int kTile = 8;    // points per register tile

int padded(int width) { return (width + kLanes - 1) / kLanes * kLanes; }

// Sixteen floats (one tile row) and a * b + c on them: AVX-512 or AVX2 fused instructions
// where the CPU has them (the network's sums need only be the same for any thread count, not
// across CPUs), else GCC vector arithmetic (a multiply and an add).
#if defined(__AVX512F__)
using V16 = __m512;
inline V16 load16(const float* p) { return _mm512_loadu_ps(p); }
inline void store16(float* p, V16 v) { _mm512_storeu_ps(p, v); }
inline V16 splat16(float x) { return _mm512_set1_ps(x); }
inline V16 mul_add16(V16 a, V16 b, V16 c) { return _mm512_fmadd_ps(a, b, c); }
inline V16 relu16(V16 v) {  // masked move, not max_ps (GCC 12 warns inside its header)
  return _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(v, _mm512_set1_ps(0.0f), _CMP_GT_OQ), v);
}
#elif defined(__AVX2__) && defined(__FMA__)
struct V16 {
  __m256 lo, hi;
};
inline V16 load16(const float* p) { return {_mm256_loadu_ps(p), _mm256_loadu_ps(p + 8)}; }
inline void store16(float* p, V16 v) {
  _mm256_storeu_ps(p, v.lo);
  _mm256_storeu_ps(p + 8, v.hi);
}
inline V16 splat16(float x) { return {_mm256_set1_ps(x), _mm256_set1_ps(x)}; }
inline V16 mul_add16(V16 a, V16 b, V16 c) {
  return {_mm256_fmadd_ps(a.lo, b.lo, c.lo), _mm256_fmadd_ps(a.hi, b.hi, c.hi)};
}
inline V16 relu16(V16 v) {
  return {_mm256_max_ps(v.lo, _mm256_set1_ps(0.0f)), _mm256_max_ps(v.hi, _mm256_set1_ps(0.0f))};
}
#else
typedef float V16 __attribute__((vector_size(64)));
inline V16 load16(const float* p) {
  V16 v;
  std::memcpy(&v, p, sizeof v);
  return v;
}
inline void store16(float* p, V16 v) { std::memcpy(p, &v, sizeof v); }
inline V16 splat16(float x) { return V16{} + x; }
inline V16 mul_add16(V16 a, V16 b, V16 c) { return a * b + c; }
inline V16 relu16(V16 v) { return v > 0 ? v : V16{}; }
#endif

// The layer's weights transposed (in × padded out, zero padded) so that a tile's outputs are
// contiguous, with the bias padded alike.
void prepare(const DenseLayer& l, float* __restrict wt, float* __restrict bias) {
  const int out = padded(l.out);
  for (int i = 0; i < l.in; ++i)
    for (int o = 0; o < out; ++o)
      wt[static_cast<std::size_t>(i) * out + o] =
          o < l.out ? l.weight[static_cast<std::size_t>(o) * l.in + i] : 0.0f;
  for (int o = 0; o < out; ++o) bias[o] = o < l.out ? l.bias[o] : 0.0f;
}

// One tile: kPoints rows of x times the 16 outputs from o0, onto the bias, in input order;
// then the activation. Padded columns stay 0.
template <int kPoints>
inline void dense_tile(const float* __restrict x, int xs, int in, const float* __restrict wt,
                       int ys, const float* __restrict bias, int o0, bool relu,
                       float* __restrict y) {
  V16 acc[kPoints];
  for (int q = 0; q < kPoints; ++q) acc[q] = load16(bias + o0);
  for (int i = 0; i < in; ++i) {
    const V16 w = load16(wt + static_cast<std::size_t>(i) * ys + o0);
    for (int q = 0; q < kPoints; ++q) acc[q] = mul_add16(w, splat16(x[q * xs + i]), acc[q]);
  }
  for (int q = 0; q < kPoints; ++q) store16(y + q * ys + o0, relu ? relu16(acc[q]) : acc[q]);
}

// y = act(W x + b) for n rows of x (stride padded(in)) into y (stride padded(out)).
void dense_rows(const DenseLayer& l, const float* __restrict x, std::size_t n, float* __restrict y,
                const float* __restrict wt, const float* __restrict bias) {
  const int in = l.in, xs = padded(l.in), ys = padded(l.out);
  const bool relu = l.activation == 1;
  std::size_t p = 0;
  for (; p + kTile <= n; p += kTile)
    for (int o0 = 0; o0 < ys; o0 += kLanes)
      dense_tile<kTile>(x + p * xs, xs, in, wt, ys, bias, o0, relu, y + p * ys);
  for (; p < n; ++p)
    for (int o0 = 0; o0 < ys; o0 += kLanes)
      dense_tile<1>(x + p * xs, xs, in, wt, ys, bias, o0, relu, y + p * ys);
}

}  // namespace

void encode_groups(const LevelEncoder& encoder, NeuralPooling pooling,
                   std::span<const float> coords, std::span<const std::size_t> offsets,
                   std::span<float> out, std::vector<float>& scratch) {
  const std::size_t groups = offsets.empty() ? 0 : offsets.size() - 1;
  if (groups == 0) return;
  // Scratch: two activation buffers (block × widest padded layer), the transposed weights and
  // biases of every layer, the block's inputs, the pooled vectors and the head's buffers.
  std::size_t width = kLanes, weights = 0;
  const auto layer_sizes = [&](const std::vector<DenseLayer>& layers) {
    for (const DenseLayer& l : layers) {
      width = std::max<std::size_t>(width, static_cast<std::size_t>(padded(std::max(l.in, l.out))));
      weights += static_cast<std::size_t>(l.in) * padded(l.out) + padded(l.out);
    }
  };
  layer_sizes(encoder.point_layers);
  layer_sizes(encoder.head_layers);
  const int feat = encoder.point_layers.back().out;
  const std::size_t feat_stride = static_cast<std::size_t>(padded(feat));
  constexpr std::size_t kBlock = 64;  // points per pass: keeps the activations in L1/L2
  const std::size_t buf = kBlock * width;
  const std::size_t need = 2 * buf + weights + kBlock * kLanes + groups * feat_stride + 2 * width;
  if (scratch.size() < need) scratch.resize(need);
  float* a = scratch.data();
  float* b = a + buf;
  float* w = b + buf;
  float* xin = w + weights;
  float* pooled = xin + kBlock * kLanes;
  float* h0 = pooled + groups * feat_stride;
  float* h1 = h0 + width;

  // Transposed weights of every layer, once per call.
  std::vector<std::pair<const float*, const float*>> prepared;
  prepared.reserve(encoder.point_layers.size() + encoder.head_layers.size());
  float* cursor = w;
  for (const auto* layers : {&encoder.point_layers, &encoder.head_layers})
    for (const DenseLayer& l : *layers) {
      float* wt = cursor;
      float* bias = wt + static_cast<std::size_t>(l.in) * padded(l.out);
      prepare(l, wt, bias);
      prepared.emplace_back(wt, bias);
      cursor = bias + padded(l.out);
    }

  const float start =
      pooling == NeuralPooling::max ? -std::numeric_limits<float>::infinity() : 0.0f;
  for (std::size_t i = 0; i < groups * feat_stride; ++i) pooled[i] = start;
  std::vector<std::size_t> active(groups, 0);
  std::uint32_t owner[kBlock];  // the group of each point of the block

  std::size_t p = offsets.front(), group = 0;
  const std::size_t end = offsets.back();
  while (p < end) {
    std::size_t n = 0;
    for (; p < end && n < kBlock; ++p) {
      while (p >= offsets[group + 1]) ++group;
      if (coords[p] == 0.0f) continue;  // masked points are exactly 0
      owner[n] = static_cast<std::uint32_t>(group);
      xin[kLanes * n++] = coords[p];
    }
    if (n == 0) continue;
    const float* x = xin;  // stride kLanes = padded(1)
    float* y = a;
    for (std::size_t k = 0; k < encoder.point_layers.size(); ++k) {
      dense_rows(encoder.point_layers[k], x, n, y, prepared[k].first, prepared[k].second);
      x = y;
      y = (y == a) ? b : a;
    }
    for (std::size_t q = 0; q < n; ++q) {
      const float* f = x + q * feat_stride;
      float* g = pooled + owner[q] * feat_stride;
      ++active[owner[q]];
      if (pooling == NeuralPooling::max)
        for (int o = 0; o < feat; ++o) g[o] = std::max(g[o], f[o]);
      else
        for (int o = 0; o < feat; ++o) g[o] += f[o];
    }
  }

  for (std::size_t gi = 0; gi < groups; ++gi) {
    float* g = pooled + gi * feat_stride;
    for (std::size_t o = static_cast<std::size_t>(feat); o < feat_stride; ++o) g[o] = 0.0f;
    if (active[gi] == 0)
      for (int o = 0; o < feat; ++o) g[o] = 0.0f;  // no active point: a defined, neutral input
    else if (pooling == NeuralPooling::mean)
      for (int o = 0; o < feat; ++o) g[o] /= static_cast<float>(active[gi]);
    const float* x = g;
    float* y = h0;
    float* other = h1;
    for (std::size_t k = 0; k < encoder.head_layers.size(); ++k) {
      const auto& [wt, bias] = prepared[encoder.point_layers.size() + k];
      dense_rows(encoder.head_layers[k], x, 1, y, wt, bias);
      x = y;
      std::swap(y, other);
    }
    out[gi] = x[0];
  }
}

float encode_axis(const LevelEncoder& encoder, NeuralPooling pooling, std::span<const float> coords,
                  std::vector<float>& scratch) {
  const std::size_t offsets[2] = {0, coords.size()};
  float out = 0;
  encode_groups(encoder, pooling, coords, offsets, std::span<float>(&out, 1), scratch);
  return out;
}

}  // namespace splitray
