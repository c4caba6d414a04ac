// What signed traffic (protocol/signing.hpp) costs per tick of the default
// scene, against the tick's own compute measured in the same run.
//
// Per tick the daemon signs every state it publishes and verifies every input
// it takes; for config/default.yaml (arm and cart-pole) that is 2 state_t
// signed and, with a setpoint streamed to each instance, 2 setpoint_t
// verified. The scene also publishes each instance's telemetry_t every tick;
// the /with-telemetry variant signs those too.
//
//   signing/default/<mac>[/with-telemetry]
//     time:          the signing and verifying of one tick's datagrams
//                    (the inputs are signed, as their sender would, outside it)
//     tick_ns:       Runtime::Tick of the same scene, timed in the same loop
//     sign_per_tick_ns, ratio_to_tick: the signing's mean cost, and that over tick_ns
//   <mac>: blake2b (keyed BLAKE2b-128, what lagrange uses: Signer/Verifier) or
//          hmac-sha256 (MAVLink 2's MAC truncated to 16 bytes, the same layout,
//          libsodium's crypto_auth_hmacsha256 with the key absorbed once)
//
// Target (issue 21): at most 2 µs per tick for the default scene's states and inputs.

#include <benchmark/benchmark.h>
#include <sodium.h>
#include <lagrange/setpoint_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/telemetry_t.hpp>

#include <chrono>
#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

#include "daemon/runtime.hpp"
#include "protocol/big_endian.hpp"
#include "protocol/signing.hpp"
#include "sim/scene.hpp"

namespace lagrange::bench {
namespace {

using Bytes = std::vector<std::uint8_t>;
using Clock = std::chrono::steady_clock;
constexpr Nanoseconds kPeriod = 1'000'000;  // 1 ms

template <class Message>
Bytes EncodedWithRoom(const Message& m) {
  Bytes b(static_cast<std::size_t>(m.getEncodedSize()) + kSignatureTrailerBytes);
  m.encode(b.data(), 0, m.getEncodedSize());
  return b;
}

// One datagram's message (with room for its trailer) and its channel.
struct Datagram {
  std::string channel;
  Bytes bytes;
  std::size_t size = 0;  // the message's, without the trailer
};

// The default scene's per-tick datagrams, at their real sizes: each instance's
// state_t (and telemetry_t) out, its setpoint_t in.
void MakeDatagrams(const Scene& scene, bool telemetry, std::vector<Datagram>& out, std::vector<Datagram>& in) {
  for (const InstanceConfig& c : scene.instances) {
    const int n = c.plant.num_dofs();
    std::string upper = c.name;
    for (char& ch : upper) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
    state_t s{};
    s.num_dofs = n;
    for (auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) v->assign(static_cast<std::size_t>(n), 0.5);
    s.controller = "computed-torque";
    out.push_back({upper + "_STATE", EncodedWithRoom(s), static_cast<std::size_t>(s.getEncodedSize())});
    if (telemetry) {
      telemetry_t t{};
      t.integrator = "rk4";
      t.method = "closed-form";
      out.push_back({upper + "_TELEMETRY", EncodedWithRoom(t), static_cast<std::size_t>(t.getEncodedSize())});
    }
    setpoint_t p{};
    p.num_dofs = n;
    for (auto* v : {&p.q, &p.qd, &p.qdd}) v->assign(static_cast<std::size_t>(n), 0.5);
    in.push_back({upper + "_SETPOINT", EncodedWithRoom(p), static_cast<std::size_t>(p.getEncodedSize())});
  }
}

BusKey BenchKey() {
  std::uint8_t bytes[kBusKeyMinBytes];
  for (std::size_t i = 0; i < sizeof bytes; ++i) bytes[i] = static_cast<std::uint8_t>(i * 37 + 11);
  return BusKey::FromBytes(bytes);
}

// The HMAC-SHA256 alternative over the same bytes as KeyedMac::Tag.
struct HmacMac {
  crypto_auth_hmacsha256_state keyed;
  explicit HmacMac(const BusKey& key) {
    crypto_auth_hmacsha256_init(&keyed, key.bytes().data(), key.bytes().size());
    const std::string personal = BusDomainBytes("udpm://239.255.76.67:7667");  // "LGS2" ‖ domain ‖ NUL, as KeyedMac
    crypto_auth_hmacsha256_update(&keyed, reinterpret_cast<const unsigned char*>(personal.data()), personal.size());
  }
  void Tag(const Datagram& d, std::uint64_t stamp, std::uint8_t* tag16) const {
    crypto_auth_hmacsha256_state s = keyed;
    static constexpr std::uint8_t kNul = 0;
    std::uint8_t nonce[16];
    WriteBigEndian64(7, nonce);
    WriteBigEndian64(stamp, nonce + 8);
    crypto_auth_hmacsha256_update(&s, reinterpret_cast<const unsigned char*>(d.channel.data()), d.channel.size());
    crypto_auth_hmacsha256_update(&s, &kNul, 1);
    crypto_auth_hmacsha256_update(&s, d.bytes.data(), d.size);
    crypto_auth_hmacsha256_update(&s, nonce, sizeof nonce);
    std::uint8_t full[crypto_auth_hmacsha256_BYTES];
    crypto_auth_hmacsha256_final(&s, full);
    std::memcpy(tag16, full, kSignatureTagBytes);
  }
};

enum class Mac : std::uint8_t { kBlake2b, kHmacSha256 };

void TimeSigning(benchmark::State& bm, Mac mac, bool telemetry) {
  Scene scene = LoadScene(std::string(LAGRANGE_SOURCE_DIR) + "/config/default.yaml");
  std::vector<Datagram> out, in;
  MakeDatagrams(scene, telemetry, out, in);
  Runtime runtime(std::move(scene));
  TickRecord record = runtime.MakeRecord();
  const BusKey key = BenchKey();
  Signer daemon(key, "udpm://239.255.76.67:7667"), client(key, "udpm://239.255.76.67:7667");
  Verifier verifier(key, "udpm://239.255.76.67:7667");
  const HmacMac hmac(key);
  std::vector<std::array<std::uint8_t, kSignatureTagBytes>> sent_tags(in.size());
  Nanoseconds now = 0;
  std::uint64_t stamp = 0;
  double tick_ns = 0.0, sign_ns = 0.0;
  for (auto _ : bm) {
    now += kPeriod;
    const auto t0 = Clock::now();
    runtime.Tick(now, record);
    const auto t1 = Clock::now();
    // The inputs as their sender signs them: not the daemon's cost.
    ++stamp;
    for (std::size_t k = 0; k < in.size(); ++k) {
      Datagram& d = in[k];
      if (mac == Mac::kBlake2b) {
        client.Sign(d.channel, d.bytes.data(), d.size, d.bytes.data() + d.size);
      } else {
        hmac.Tag(d, stamp, sent_tags[k].data());
      }
    }
    const auto t2 = Clock::now();
    bool ok = true;
    for (Datagram& d : out) {
      if (mac == Mac::kBlake2b) {
        daemon.Sign(d.channel, d.bytes.data(), d.size, d.bytes.data() + d.size);
      } else {
        hmac.Tag(d, stamp, d.bytes.data() + d.size + 16);
      }
    }
    for (std::size_t k = 0; k < in.size(); ++k) {
      const Datagram& d = in[k];
      if (mac == Mac::kBlake2b) {
        std::size_t size = 0;
        ok = ok &&
             verifier.Verify(d.channel, d.bytes.data(), d.size + kSignatureTrailerBytes, size) == SignatureVerdict::kOk;
      } else {
        std::uint8_t expected[kSignatureTagBytes];
        hmac.Tag(d, stamp, expected);
        ok = ok && sodium_memcmp(expected, sent_tags[k].data(), kSignatureTagBytes) == 0;
      }
    }
    const auto t3 = Clock::now();
    if (!ok) {
      bm.SkipWithError("a signed input did not verify");
      return;
    }
    benchmark::ClobberMemory();
    const double signing = std::chrono::duration<double, std::nano>(t3 - t2).count();
    bm.SetIterationTime(signing * 1e-9);
    tick_ns += std::chrono::duration<double, std::nano>(t1 - t0).count();
    sign_ns += signing;
  }
  const auto iterations = static_cast<double>(bm.iterations());
  bm.counters["tick_ns"] = tick_ns / iterations;
  bm.counters["sign_per_tick_ns"] = sign_ns / iterations;
  bm.counters["ratio_to_tick"] = sign_ns / tick_ns;
  bm.counters["datagrams"] = static_cast<double>(out.size() + in.size());
}

}  // namespace
}  // namespace lagrange::bench

int main(int argc, char** argv) {
  using lagrange::bench::Mac;
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  for (const auto& [name, mac] : {std::pair{"blake2b", Mac::kBlake2b}, std::pair{"hmac-sha256", Mac::kHmacSha256}}) {
    for (const bool telemetry : {false, true}) {
      const Mac m = mac;
      benchmark::RegisterBenchmark(
          (std::string("signing/default/") + name + (telemetry ? "/with-telemetry" : "")).c_str(),
          [m, telemetry](benchmark::State& bm) { lagrange::bench::TimeSigning(bm, m, telemetry); })
          ->UseManualTime()
          ->Unit(benchmark::kNanosecond);
    }
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
