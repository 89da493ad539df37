// GoogleTest suite of the C++ codec: the shared golden vectors, the CRC, and hand-made cases.
#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <type_traits>
#include <vector>

#include "jackson/protocol/frame.hpp"

namespace jp = jackson::protocol;
using nlohmann::json;

namespace {

template <class T>
struct is_text : std::false_type {};
template <size_t N>
struct is_text<jp::Text<N>> : std::true_type {};

json load(const std::string& name) {
  std::ifstream in(std::string(JACKSON_VECTORS_DIR) + "/" + name);
  EXPECT_TRUE(in.good()) << "cannot open " << name;
  return json::parse(in);
}

std::vector<uint8_t> unhex(const std::string& hex) {
  std::vector<uint8_t> out;
  for (size_t i = 0; i + 1 < hex.size(); i += 2) {
    out.push_back(static_cast<uint8_t>(std::stoul(hex.substr(i, 2), nullptr, 16)));
  }
  return out;
}

// ---- struct <-> JSON through the generated for_each_field --------------------------------
template <class T>
json value_to_json(const T& v) {
  if constexpr (std::is_arithmetic_v<T>) {
    if constexpr (std::is_floating_point_v<T>) {
      return static_cast<double>(v);
    } else {
      return static_cast<int64_t>(v);
    }
  } else if constexpr (is_text<T>::value) {
    return std::string(v.data.data(), v.len);
  } else {
    json arr = json::array();
    for (const auto& x : v) arr.push_back(value_to_json(x));
    return arr;
  }
}

template <class T>
void value_from_json(const json& j, T& v) {
  if constexpr (std::is_arithmetic_v<T>) {
    v = j.get<T>();
  } else if constexpr (is_text<T>::value) {
    const std::string s = j.get<std::string>();
    v.assign(s.data(), s.size());
  } else {
    ASSERT_EQ(j.size(), v.size());
    for (size_t i = 0; i < v.size(); ++i) value_from_json(j[i], v[i]);
  }
}

template <class Msg>
json to_json(const Msg& m) {
  json out = json::object();
  m.for_each_field([&](const char* name, const auto& v) { out[name] = value_to_json(v); });
  return out;
}

// Decodes a frame's payload by TYPE into JSON fields; returns the schema name.
std::string frame_to_json(const jp::Frame& f, json& fields) {
  std::string name;
  const bool known = jp::visit_message(f.type, f.payload, f.len, [&](const auto& msg) {
    fields = to_json(msg);
    name = std::decay_t<decltype(msg)>::kName;
  });
  EXPECT_TRUE(known);
  return name;
}

// Encodes the message described by (name, fields, seq) into a frame.
std::vector<uint8_t> encode_from_json(const std::string& name, const json& fields, uint8_t seq) {
  std::vector<uint8_t> out(jp::kMaxFrame);
  size_t n = 0;
  bool found = false;
  for (int type = 0; type < 256; ++type) {
    const char* tname = jp::message_name(static_cast<uint8_t>(type));
    if (tname == nullptr || name != tname) continue;
    found = true;
    static const uint8_t kNothing[1] = {0};
    jp::visit_message(static_cast<uint8_t>(type), kNothing, 0, [&](auto msg) {
      msg.for_each_field([&](const char* field, auto& v) { value_from_json(fields.at(field), v); });
      n = jp::encode_frame(msg, seq, out.data(), out.size());
    });
  }
  EXPECT_TRUE(found) << "no message named " << name;
  out.resize(n);
  return out;
}

json counters_to_json(const jp::DecoderCounters& c) {
  return json{{"frames_ok", c.frames_ok},       {"crc_errors", c.crc_errors},
              {"bytes_skipped", c.bytes_skipped}, {"oversize", c.oversize},
              {"unknown_version", c.unknown_version}, {"unknown_type", c.unknown_type},
              {"seq_gaps", c.seq_gaps},           {"seq_lost", c.seq_lost},
              {"timeouts", c.timeouts}};
}

}  // namespace

TEST(Crc32c, MatchesTheCheckValue) {
  const uint8_t check[] = {'1', '2', '3', '4', '5', '6', '7', '8', '9'};
  EXPECT_EQ(jp::crc32c(check, sizeof check), 0xE3069283u);
  EXPECT_EQ(jp::crc32c(nullptr, 0), 0u);
}

TEST(Vectors, SchemaHashMatchesTheVectors) {
  const json doc = load("messages.json");
  EXPECT_EQ(doc.at("protocol_version").get<int>(), jp::kProtocolVersion);
  EXPECT_EQ(std::stoul(doc.at("schema_hash").get<std::string>(), nullptr, 16), jp::kSchemaHash);
}

TEST(Vectors, EveryMessageEncodesToTheGoldenBytes) {
  const json doc = load("messages.json");
  ASSERT_FALSE(doc.at("vectors").empty());
  for (const json& v : doc.at("vectors")) {
    SCOPED_TRACE(v.at("name").get<std::string>());
    const auto expected = unhex(v.at("hex").get<std::string>());
    const auto bytes = encode_from_json(v.at("message").get<std::string>(), v.at("fields"),
                                        v.at("seq").get<uint8_t>());
    EXPECT_EQ(bytes, expected);
  }
}

TEST(Vectors, EveryMessageDecodesToTheGoldenFields) {
  const json doc = load("messages.json");
  for (const json& v : doc.at("vectors")) {
    SCOPED_TRACE(v.at("name").get<std::string>());
    const auto bytes = unhex(v.at("hex").get<std::string>());
    jp::FrameDecoder dec;
    int frames = 0;
    dec.feed(bytes.data(), bytes.size(), 0, [&](const jp::Frame& f) {
      ++frames;
      json fields;
      EXPECT_EQ(frame_to_json(f, fields), v.at("message").get<std::string>());
      EXPECT_EQ(f.seq, v.at("seq").get<int>());
      EXPECT_EQ(fields, v.at("fields"));
    });
    EXPECT_EQ(frames, 1);
    EXPECT_EQ(dec.pending(), 0u);
  }
}

TEST(Vectors, EveryStreamGivesTheGoldenFramesAndCounters) {
  const json doc = load("streams.json");
  ASSERT_FALSE(doc.at("vectors").empty());
  for (const json& v : doc.at("vectors")) {
    SCOPED_TRACE(v.at("name").get<std::string>());
    jp::FrameDecoder dec;
    json frames = json::array();
    auto sink = [&](const jp::Frame& f) {
      json fields;
      const std::string name = frame_to_json(f, fields);
      frames.push_back(json{{"message", name}, {"seq", f.seq}, {"fields", fields}});
    };
    for (const json& chunk : v.at("chunks")) {
      const auto bytes = unhex(chunk.at("hex").get<std::string>());
      dec.feed(bytes.data(), bytes.size(), chunk.at("at_us").get<uint32_t>(), sink);
    }
    if (!v.at("poll_at_us").is_null()) dec.poll(v.at("poll_at_us").get<uint32_t>(), sink);
    EXPECT_EQ(frames, v.at("frames"));
    EXPECT_EQ(counters_to_json(dec.counters()), v.at("counters"));
    EXPECT_EQ(dec.pending(), v.at("pending").get<size_t>());
  }
}

TEST(Frame, TelemetryFrameIs38Bytes) {
  jp::Telemetry t;
  uint8_t buf[jp::kMaxFrame];
  EXPECT_EQ(jp::encode_frame(t, 0, buf, sizeof buf), 38u);
}

TEST(Frame, EncodeRefusesASmallBuffer) {
  jp::Telemetry t;
  uint8_t buf[37];
  EXPECT_EQ(jp::encode_frame(t, 0, buf, sizeof buf), 0u);
}

TEST(Frame, HandBuiltAckDecodes) {
  // A5 5A | VER 01 | TYPE 04 | SEQ 09 | LEN 02 | 83 09 | CRC-32C over 01 04 09 02 83 09
  std::vector<uint8_t> f = {0xA5, 0x5A, 0x01, 0x04, 0x09, 0x02, 0x83, 0x09};
  const uint32_t crc = jp::crc32c(f.data() + 2, 6);
  for (int i = 0; i < 4; ++i) f.push_back(static_cast<uint8_t>(crc >> (8 * i)));
  jp::FrameDecoder dec;
  jp::Ack ack;
  int n = 0;
  dec.feed(f.data(), f.size(), 0, [&](const jp::Frame& fr) { n += fr.as(ack) ? 1 : 0; });
  EXPECT_EQ(n, 1);
  EXPECT_EQ(ack.acked_type, 0x83);
  EXPECT_EQ(ack.acked_seq, 9);
}

TEST(Frame, LogTextIsTruncatedToItsCapacity) {
  jp::Log log;
  const std::string long_text(300, 'x');
  log.text.assign(long_text.data(), long_text.size());
  EXPECT_EQ(log.text.len, 100);
  uint8_t buf[jp::kMaxFrame];
  EXPECT_EQ(jp::encode_frame(log, 0, buf, sizeof buf), 6u + 1u + 100u + 4u);
}

TEST(Decoder, TimeoutAcrossTheClockWrap) {
  jp::Telemetry t;
  uint8_t buf[jp::kMaxFrame];
  const size_t n = jp::encode_frame(t, 0, buf, sizeof buf);
  jp::FrameDecoder dec;
  int frames = 0;
  auto sink = [&](const jp::Frame&) { ++frames; };
  dec.feed(buf, 10, 0xFFFFF000u, sink);               // partial frame just before the wrap
  dec.feed(buf + 10, n - 10, 0x00000100u, sink);      // 4.35 ms later, after the wrap
  EXPECT_EQ(frames, 1);
  EXPECT_EQ(dec.counters().timeouts, 0u);
  dec.feed(buf, 10, 0x00000200u, sink);
  dec.poll(0x00000200u + jp::kPartialTimeoutUs, sink);
  EXPECT_EQ(dec.counters().timeouts, 1u);
  EXPECT_EQ(dec.pending(), 0u);
}
