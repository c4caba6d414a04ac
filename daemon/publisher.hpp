#pragma once
// The daemon's publish thread: it meets the tick only at the record ring (and
// the eventfd the tick writes), and speaks LCM's wire format through
// protocol/bus.hpp, never through lcm::LCM (see there why).
//
// Publisher: waits on an eventfd the tick writes, turns each tick record into
// a torque_t on an external plant's torque_channel (first: it is the latency
// that counts), one state_t per instance on <NAME>_STATE, a reply_t per
// command verdict on <NAME>_REPLY, a telemetry_t and a forces_t where asked,
// an mpc_t on <NAME>_MPC for each plan an mpc instance's tick took, a
// base_state_t on <NAME>_BASE every tick for a floating base,
// and every 0.1 s of ticks a status_t on LAGRANGE_STATUS (with every
// instance's joint names, from JointNamesOf, escaped; protocol/status.hpp
// says what a status carries). It also logs mode changes, faults and refused
// commands, at most once a second per kind of line.
//
// Every string that came from the bus is escaped (base/escape.hpp) before
// it is logged or published.

#include <lagrange/base_state_t.hpp>
#include <lagrange/forces_t.hpp>
#include <lagrange/mpc_t.hpp>
#include <lagrange/reply_t.hpp>
#include <lagrange/state_t.hpp>
#include <lagrange/status_t.hpp>
#include <lagrange/task_state_t.hpp>
#include <lagrange/telemetry_t.hpp>
#include <lagrange/torque_t.hpp>

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>

#include "daemon/loop.hpp"
#include "daemon/receiver.hpp"
#include "daemon/runtime.hpp"
#include "daemon/throttle.hpp"
#include "protocol/bus.hpp"

namespace lagrange {

class TimingCsvWriter;

class Publisher {
 public:
  // Publishes the records of `runtime` (whose model it reads: channels,
  // names, joint names) that the tick puts in `ring`.
  Publisher(Bus& output, const Runtime& runtime, SpscRing<TickRecord>& ring, const Loop& loop, ReceiverStats& stats,
            int notify_fd, std::int64_t run_id);

  // Publishes records as they come until `stop` is set.
  void Run(const std::atomic<bool>& stop);
  // Publishes whatever is left in the ring and a final status.
  void Drain();

  // --timing-csv: from now on also offers every tick's timing to `writer`,
  // which writes it to its file on a thread of its own (never this one).
  void SetTimingWriter(TimingCsvWriter* writer) { timing_ = writer; }

  std::int64_t states_published() const { return states_published_; }

 private:
  void Publish(const TickRecord& record);
  void PublishReplies(std::size_t i, const InstanceRecord& r, std::int64_t utime);
  void PublishTorque(std::size_t i, const InstanceRecord& r, std::int64_t utime);
  void PublishTelemetry(std::size_t i, const InstanceRecord& r, const TickRecord& record);
  void PublishForces(std::size_t i, const InstanceRecord& r, const TickRecord& record);
  void PublishTask(std::size_t i, const InstanceRecord& r, const TickRecord& record);
  void PublishMpc(std::size_t i, const InstanceRecord& r, const TickRecord& record);
  void PublishBase(std::size_t i, const InstanceRecord& r, const TickRecord& record);
  void PublishStatus(const TickRecord& last);
  void LogEvents(const TickRecord& record);
  std::string StatusReason(std::size_t i, const InstanceRecord& r) const;

  // One instance's messages, kept between ticks (their vectors keep their
  // capacity), and its mode and reason as last logged.
  struct Outgoing {
    state_t state{};
    torque_t torque{};  // an external plant's command; its sequence counts from 0
    telemetry_t telemetry{};
    task_state_t task{};
    base_state_t base{};
    mpc_t mpc{};  // sized once for the instance's plans (MpcKnotsOnWire)
    forces_t forces{};
    Mode mode = Mode::kRunning;
    const char* reason = nullptr;
    bool logged = false;             // a record of it was seen: mode and reason are its
    bool residual_exceeded = false;  // as last logged
  };

  Bus& bus_;
  const DaemonModel& model_;
  SpscRing<TickRecord>& ring_;
  const Loop& loop_;
  ReceiverStats& stats_;
  int notify_fd_;
  std::int64_t run_id_;
  int status_every_;
  std::vector<Outgoing> out_;                 // by instance
  status_t status_;                           // the run's fixed fields filled once
  std::vector<double> latencies_, computes_;  // µs, this status window
  std::int64_t commands_applied_ = 0;         // by the tick, from its records
  std::int64_t commands_refused_by_tick_ = 0;
  std::string last_setpoint_rejection_, last_command_error_;
  std::int64_t states_published_ = 0;
  bool have_record_ = false;
  TickRecord last_;
  reply_t reply_;
  LogThrottle refusal_throttle_;
  TokenBucket reply_budget_{kMaxRepliesPerSecond, kMaxRepliesPerSecond};
  TimingCsvWriter* timing_ = nullptr;
};

}  // namespace lagrange
