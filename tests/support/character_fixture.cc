// The .character fixture format (character_fixture.h).
#include "support/character_fixture.h"

#include <cstdint>
#include <cstring>
#include <type_traits>

namespace skinspheres::test {
namespace {

constexpr char kMagic[8] = {'S', 'K', 'S', 'C', 'H', 'R', '0', '1'};

class Writer {
 public:
  template <class T>
  void Pod(const T& v) {
    static_assert(std::is_trivially_copyable_v<T>);
    out_.append(reinterpret_cast<const char*>(&v), sizeof(T));
  }
  void Count(size_t n) { Pod(static_cast<uint32_t>(n)); }
  void String(const std::string& s) {
    Count(s.size());
    out_ += s;
  }
  void Floats(const float* f, size_t n) { out_.append(reinterpret_cast<const char*>(f), n * sizeof(float)); }
  void Vec3(const Eigen::Vector3f& v) { Floats(v.data(), 3); }
  void Quat(const Quatf& q) { Floats(q.coeffs().data(), 4); }
  template <class T, class F>
  void Array(const std::vector<T>& items, F&& each) {
    Count(items.size());
    for (const T& item : items) each(item);
  }
  std::string take() { return std::move(out_); }

 private:
  std::string out_;
};

class Reader {
 public:
  explicit Reader(const std::string& bytes) : p_(bytes.data()), end_(bytes.data() + bytes.size()) {}
  bool ok() const { return ok_; }
  bool at_end() const { return p_ == end_; }

  template <class T>
  T Pod() {
    T v{};
    if (!Take(sizeof(T))) return v;
    std::memcpy(&v, p_ - sizeof(T), sizeof(T));
    return v;
  }
  // A count of elements of at least `element_bytes` each, checked against the bytes left.
  size_t Count(size_t element_bytes) {
    const uint32_t n = Pod<uint32_t>();
    if (element_bytes > 0 && n > static_cast<size_t>(end_ - p_) / element_bytes) ok_ = false;
    return ok_ ? n : 0;
  }
  std::string String() {
    const size_t n = Count(1);
    if (!Take(n)) return {};
    return std::string(p_ - n, n);
  }
  void Floats(float* f, size_t n) {
    if (Take(n * sizeof(float))) std::memcpy(f, p_ - n * sizeof(float), n * sizeof(float));
  }
  Eigen::Vector3f Vec3() {
    Eigen::Vector3f v = Eigen::Vector3f::Zero();
    Floats(v.data(), 3);
    return v;
  }
  Quatf Quat() {
    Quatf q = Quatf::Identity();
    Floats(q.coeffs().data(), 4);
    return q;
  }
  template <class T, class F>
  void Array(std::vector<T>* items, size_t element_bytes, F&& each) {
    const size_t n = Count(element_bytes);
    items->clear();
    for (size_t k = 0; k < n && ok_; ++k) items->push_back(each());
  }
  bool Magic() {
    if (!Take(sizeof(kMagic))) return false;
    return std::memcmp(p_ - sizeof(kMagic), kMagic, sizeof(kMagic)) == 0;
  }

 private:
  bool Take(size_t n) {
    if (!ok_ || n > static_cast<size_t>(end_ - p_)) {
      ok_ = false;
      return false;
    }
    p_ += n;
    return true;
  }
  const char* p_;
  const char* end_;
  bool ok_ = true;
};

template <class V, class Put>
void WriteTrack(Writer& w, const skinning::Track<V>& t, Put&& put) {
  w.Pod(static_cast<uint8_t>(t.interpolation));
  w.Array(t.times_s, [&](float x) { w.Pod(x); });
  w.Array(t.values, put);
}

template <class V, class Get>
skinning::Track<V> ReadTrack(Reader& r, size_t value_bytes, Get&& get) {
  skinning::Track<V> t;
  t.interpolation = static_cast<skinning::Interpolation>(r.Pod<uint8_t>());
  r.Array(&t.times_s, 4, [&] { return r.Pod<float>(); });
  r.Array(&t.values, value_bytes, get);
  return t;
}

}  // namespace

std::string WriteCharacter(const Character& c) {
  Writer w;
  for (char m : kMagic) w.Pod(m);
  w.String(c.source_file);
  w.Array(c.skeleton.joint_names, [&](const std::string& s) { w.String(s); });
  w.Array(c.skeleton.parents, [&](int32_t p) { w.Pod(p); });
  w.Array(c.skeleton.rest_local, [&](const skinning::Transform& t) {
    w.Vec3(t.translation);
    w.Quat(t.rotation);
    w.Vec3(t.scale);
  });
  w.Array(c.clips, [&](const skinning::AnimationClip& clip) {
    w.String(clip.name);
    w.Pod(clip.duration_s);
    w.Array(clip.tracks, [&](const skinning::JointTrack& tr) {
      w.Pod(tr.joint);
      WriteTrack(w, tr.translation, [&](const Eigen::Vector3f& v) { w.Vec3(v); });
      WriteTrack(w, tr.rotation, [&](const Quatf& q) { w.Quat(q); });
      WriteTrack(w, tr.scale, [&](const Eigen::Vector3f& v) { w.Vec3(v); });
    });
  });
  w.Array(c.skin.positions_bind, [&](const Eigen::Vector3f& v) { w.Vec3(v); });
  w.Array(c.skin.binds, [&](const skinning::BindEntry& b) {
    w.Pod(b.joint);
    w.Floats(b.inverse_bind.data(), 16);
  });
  w.Array(c.skin.influence_offsets, [&](uint32_t x) { w.Pod(x); });
  w.Array(c.skin.influence_binds, [&](uint16_t x) { w.Pod(x); });
  w.Array(c.skin.influence_weights, [&](float x) { w.Pod(x); });
  w.Array(c.positions_rest, [&](const Eigen::Vector3f& v) { w.Vec3(v); });
  w.Array(c.triangles, [&](const Eigen::Vector3i& t) {
    for (int k = 0; k < 3; ++k) w.Pod(static_cast<int32_t>(t[k]));
  });
  return w.take();
}

std::optional<Character> ReadCharacter(const std::string& bytes, std::string* error) {
  Reader r(bytes);
  Character c;
  if (!r.Magic()) {
    *error = "not a .character fixture (no SKSCHR01 header)";
    return std::nullopt;
  }
  c.source_file = r.String();
  r.Array(&c.skeleton.joint_names, 4, [&] { return r.String(); });
  r.Array(&c.skeleton.parents, 4, [&] { return r.Pod<int32_t>(); });
  r.Array(&c.skeleton.rest_local, 40, [&] {
    skinning::Transform t;
    t.translation = r.Vec3();
    t.rotation = r.Quat();
    t.scale = r.Vec3();
    return t;
  });
  r.Array(&c.clips, 12, [&] {
    skinning::AnimationClip clip;
    clip.name = r.String();
    clip.duration_s = r.Pod<float>();
    r.Array(&clip.tracks, 4, [&] {
      skinning::JointTrack tr;
      tr.joint = r.Pod<int32_t>();
      tr.translation = ReadTrack<Eigen::Vector3f>(r, 12, [&] { return r.Vec3(); });
      tr.rotation = ReadTrack<Quatf>(r, 16, [&] { return r.Quat(); });
      tr.scale = ReadTrack<Eigen::Vector3f>(r, 12, [&] { return r.Vec3(); });
      return tr;
    });
    return clip;
  });
  r.Array(&c.skin.positions_bind, 12, [&] { return r.Vec3(); });
  r.Array(&c.skin.binds, 68, [&] {
    skinning::BindEntry b;
    b.joint = r.Pod<int32_t>();
    r.Floats(b.inverse_bind.data(), 16);
    return b;
  });
  r.Array(&c.skin.influence_offsets, 4, [&] { return r.Pod<uint32_t>(); });
  r.Array(&c.skin.influence_binds, 2, [&] { return r.Pod<uint16_t>(); });
  r.Array(&c.skin.influence_weights, 4, [&] { return r.Pod<float>(); });
  r.Array(&c.positions_rest, 12, [&] { return r.Vec3(); });
  r.Array(&c.triangles, 12, [&] {
    Eigen::Vector3i t;
    for (int k = 0; k < 3; ++k) t[k] = r.Pod<int32_t>();
    return t;
  });
  if (!r.ok() || !r.at_end()) {
    *error = r.ok() ? "trailing bytes after the triangles" : "truncated or inconsistent counts";
    return std::nullopt;
  }
  if (!c.skeleton.Validate()) {
    *error = "inconsistent skeleton";
    return std::nullopt;
  }
  return c;
}

std::filesystem::path FixtureDir() { return std::filesystem::path(SKINSPHERES_FIXTURE_DIR); }

}  // namespace skinspheres::test
