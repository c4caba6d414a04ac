// What one refused datagram costs the receiving thread (issue 21, "a cheaper
// drop path"), per datagram, in one run: a socket on a private port
// (udpm://239.255.76.67:--port, this host only) is filled with 512 datagrams
// of a flood, then emptied
//   - by lagrange::Bus::Drain (recvmmsg, up to 16 datagrams per system call,
//     each parsed and dispatched; the bus subscribed to ARM_STATE, with or
//     without a key), and
//   - by the baseline in the same run: one recvmsg per datagram, then
//     lagrange::ParseDatagram: the read path Drain had before batching.
// Floods: garbage (200 bytes, not LCM) and refused states (an LC02 state_t
// on ARM_STATE; on the signed bus with a trailer whose tag does not verify,
// so that each costs a MAC). Only the emptying is timed.
//
//   build/bench/drain_bench [--port P] [Google Benchmark flags]

#include <benchmark/benchmark.h>
#include <unistd.h>
#include <lagrange/state_t.hpp>

#include <chrono>
#include <cstring>
#include <string>
#include <vector>

#include "bench/harness.hpp"
#include "protocol/big_endian.hpp"
#include "protocol/bus.hpp"
#include "protocol/signing.hpp"

namespace lagrange {
namespace {

int g_port = 7770;
constexpr int kFill = 512;

std::string Url() { return "udpm://239.255.76.67:" + std::to_string(g_port) + "?ttl=0&recv_buf_size=4194304"; }


using bench::Bytes;

Bytes Garbage() {
  Bytes b(200, 0x5a);
  b[0] = 'X';
  return b;
}

// An LC02 state_t on ARM_STATE; with `trailer`, a signature trailer whose tag does not verify.
Bytes RefusedState(bool trailer) {
  state_t s;
  s.utime = bench::WallMicros();
  s.run_id = 0x1234;
  s.tick = 1;
  s.num_dofs = 2;
  for (auto* v : {&s.q, &s.qd, &s.qdd, &s.tau, &s.q_des, &s.qd_des}) v->assign(2, 0.0);
  Bytes payload(static_cast<std::size_t>(s.getEncodedSize()) + (trailer ? kSignatureTrailerBytes : 0), 0xa5);
  s.encode(payload.data(), 0, s.getEncodedSize());
  Bytes b = bench::Lc02(1, "ARM_STATE", payload);
  if (trailer) {
    std::uint8_t* t = b.data() + b.size() - kSignatureTrailerBytes;
    WriteBigEndian64(0xf100d, t);
    WriteBigEndian64(static_cast<std::uint64_t>(bench::WallMicros()), t + 8);  // in the window: the tag is computed
    std::memcpy(t + 32, "LGS2", 4);
  }
  return b;
}

// A bus's receive socket opened by subscribing; a key for the signed cases.
const BusKey& TestKey() {
  static const BusKey key = [] {
    std::vector<std::uint8_t> bytes(32);
    for (std::size_t i = 0; i < bytes.size(); ++i) bytes[i] = static_cast<std::uint8_t>(7 + 31 * i);
    return BusKey::FromBytes(bytes);
  }();
  return key;
}

enum Flood { kGarbage = 0, kRefusedState = 1 };

void Drained(benchmark::State& state, std::int64_t handled) {
  state.counters["datagrams/iteration"] = benchmark::Counter(static_cast<double>(handled) / state.iterations());
  state.SetItemsProcessed(handled);
}

// Bus::Drain: recvmmsg in batches, parse, check the signature (signed), dispatch.
void BM_BusDrain(benchmark::State& state) {
  const bool signed_bus = state.range(1) != 0;
  auto bus = OpenBus(Url(), signed_bus ? &TestKey() : nullptr);
  bus->Subscribe("ARM_STATE", [](std::string_view, const std::uint8_t*, std::size_t) {});
  while (bus->Drain(1 << 20) > 0) {
  }
  bench::RawSender sender(g_port);
  const Bytes datagram = state.range(0) == kGarbage ? Garbage() : RefusedState(signed_bus);
  std::int64_t handled = 0;
  for (auto _ : state) {
    state.PauseTiming();
    for (int k = 0; k < kFill; ++k) sender.Send(datagram);
    state.ResumeTiming();
    int n = 0;
    while ((n = bus->Drain(1 << 20)) > 0) handled += n;
  }
  Drained(state, handled);
}

// The baseline: one recvmsg per datagram on a socket joined the same way, and ParseDatagram.
void BM_RecvmsgEach(benchmark::State& state) {
  // The bus opens and joins the socket; the baseline reads the same socket through its fd.
  auto bus = OpenBus(Url());
  bus->Subscribe("ARM_STATE", [](std::string_view, const std::uint8_t*, std::size_t) {});
  while (bus->Drain(1 << 20) > 0) {
  }
  bench::RawSender sender(g_port);
  const Bytes datagram = state.range(0) == kGarbage ? Garbage() : RefusedState(false);
  std::vector<std::uint8_t> buffer(64 * 1024 + 256);
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(std::uint32_t))];
  std::int64_t handled = 0, messages = 0;
  for (auto _ : state) {
    state.PauseTiming();
    for (int k = 0; k < kFill; ++k) sender.Send(datagram);
    state.ResumeTiming();
    while (true) {
      iovec iov{buffer.data(), buffer.size()};
      msghdr msg{};
      msg.msg_iov = &iov;
      msg.msg_iovlen = 1;
      msg.msg_control = control;
      msg.msg_controllen = sizeof control;
      const ssize_t n = recvmsg(bus->fd(), &msg, MSG_DONTWAIT);
      if (n < 0) break;
      ++handled;
      const Datagram d = ParseDatagram(buffer.data(), static_cast<std::size_t>(n), kMaxMessageSize);
      messages += d.kind == Datagram::Kind::kMessage ? 1 : 0;
    }
  }
  benchmark::DoNotOptimize(messages);
  Drained(state, handled);
}

BENCHMARK(BM_RecvmsgEach)->ArgNames({"refused_state", "signed"})->Args({kGarbage, 0})->Args({kRefusedState, 0});
BENCHMARK(BM_BusDrain)
    ->ArgNames({"refused_state", "signed"})
    ->Args({kGarbage, 0})
    ->Args({kRefusedState, 0})
    ->Args({kGarbage, 1})
    ->Args({kRefusedState, 1});

}  // namespace
}  // namespace lagrange

int main(int argc, char** argv) {
  // --port P (before Google Benchmark's own flags).
  std::vector<char*> rest;
  for (int k = 0; k < argc; ++k) {
    if (std::strcmp(argv[k], "--port") == 0 && k + 1 < argc) {
      lagrange::g_port = std::atoi(argv[++k]);
    } else {
      rest.push_back(argv[k]);
    }
  }
  int n = static_cast<int>(rest.size());
  benchmark::Initialize(&n, rest.data());
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
