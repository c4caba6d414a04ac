#pragma once
// What lagrangectl's live commands share: the bus options, waiting for an
// instance's state and the daemon's status, with timeouts that become one
// clear error line.

#include <lcm/lcm-cpp.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>

#include <CLI/CLI.hpp>
#include <chrono>
#include <optional>
#include <string>

namespace lagrange::cli {

struct BusOptions {
  std::string lcm_url;         // "" → $LCM_DEFAULT_URL → udpm://239.255.76.67:7667?ttl=0
  std::string channel_prefix;  // as given to lagranged --channel-prefix
  double wait = 3.0;           // s to wait for the daemon before giving up

  void AddTo(CLI::App& app);
  std::string Url() const;
  std::string Channel(const std::string& instance, const char* suffix) const;  // PREFIX + NAME_UPPER + suffix
  std::string StatusChannel() const;
};

// Keeps the latest state of one instance and the latest status, handling
// LCM on the caller's thread (Pump).
class DaemonLink {
 public:
  DaemonLink(const BusOptions& bus, const std::string& instance);

  lcm::LCM& lcm() { return lcm_; }
  // Handles messages for up to `seconds`.
  void Pump(double seconds);
  // Waits for the first state of the instance; throws a one-line error when
  // none comes within the bus's wait.
  const state_t& AwaitState();
  const status_t& AwaitStatus();
  // Handles messages until `done` holds or `seconds` pass; returns whether it held.
  template <class Predicate>
  bool PumpUntil(Predicate done, double seconds) {
    const auto end = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
    while (!done()) {
      if (std::chrono::steady_clock::now() >= end) return false;
      lcm_.handleTimeout(10);
    }
    return true;
  }

  const std::optional<state_t>& state() const { return state_; }
  const std::optional<status_t>& status() const { return status_; }
  std::int64_t states_received() const { return states_received_; }
  std::int64_t statuses_received() const { return statuses_received_; }

 private:
  void OnState(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void OnStatus(const lcm::ReceiveBuffer* rbuf, const std::string& channel);

  BusOptions bus_;
  std::string instance_;
  lcm::LCM lcm_;
  std::optional<state_t> state_;
  std::optional<status_t> status_;
  std::int64_t states_received_ = 0;
  std::int64_t statuses_received_ = 0;
};

// Wall clock, µs since the Unix epoch.
std::int64_t WallMicros();

}  // namespace lagrange::cli
