#pragma once
// lagrangectl view's HTTP connections: cpp-httplib's request handling behind a
// gate that keeps slow, idle and surplus connections from holding its threads.
//
// Debian 12's cpp-httplib (0.11) gives every accepted connection a thread of
// its pool from accept to close, and queues connections without bound while
// those threads are busy. Its read timeout is per read (a byte every few
// seconds keeps a request alive for ever), and it reads a request line and
// header lines of any length. 30 clients sending their headers a byte at a
// time (slowloris), or 1000 that connect and say nothing, so hold every
// thread, and a browser's GET / waits behind them for as long as they stay.
// httplib has no per-request deadline, no per-address limit, and no way to
// refuse a connection when its pool is full: the one hook between accept and
// its pool, TaskQueue::enqueue, gets a closure, not the socket. So the view
// takes each accepted socket itself (Server::process_and_close_socket, which
// httplib calls through its vtable) and lends httplib's request handling
// (Server::process_request) a stream over the header it has read:
//
//   - a connection waits for its request header in one thread (poll), not in
//     the pool; it gets a pool thread only once its whole header (through the
//     blank line) is in, within kHeaderSeconds of connecting (or of its
//     previous response, on a kept-alive connection) and within
//     kMaxHeaderBytes (else 431); a connection that is late is closed;
//   - at most kMaxWaitingPerAddress connections of one client address wait
//     at once, and kMaxWaiting in all: one more closes the oldest waiting
//     (of that address, else of all). A browser's request comes with its
//     connection, so the newest connection is the one to keep: a flood of
//     idle connections churns only itself, and never locks out a client, nor
//     everyone behind the same address (a NAT);
//   - a complete request that finds every pool thread busy is answered 503
//     at once and closed, never queued;
//   - a request is served by httplib as it serves any, and reads nothing but
//     its header: a body (a GET has none; other methods are refused before
//     theirs is read: routes.cpp) reads as the end of the stream.
//
// Connections in service are bounded by the pool (threads) and httplib's
// write timeout (a reader that stops reading frees its thread within it).

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include <httplib.h>

namespace lagrange::cli::view {

inline constexpr double kHeaderSeconds = 5.0;               // from connecting (or the last response) to the blank line
inline constexpr std::size_t kMaxHeaderBytes = 16u << 10;   // a request line and its headers
inline constexpr std::size_t kMaxWaitingPerAddress = 32;    // connections of one address waiting for their header
inline constexpr std::size_t kMaxWaiting = 256;             // all of them (each an open file)
inline constexpr int kMaxRequestsPerConnection = 100;       // kept alive for at most this many requests

// One client connection between requests: its socket, its address, and what
// it has sent of its next request.
struct GateConnection {
  int fd = -1;
  std::string address;  // the client's IP address, as text
  std::string header;   // bytes received and not yet served
  std::chrono::steady_clock::time_point deadline;  // for its whole header
  std::uint64_t order = 0;                         // admission order: the smallest is the oldest
  int served = 0;                                  // requests answered on it
};

// Threads that each serve one request at a time; a request is taken only by
// a thread that is free (TryRun), never queued.
class GatePool {
 public:
  using Serve = std::function<void(GateConnection)>;
  GatePool(int threads, Serve serve);
  ~GatePool() { Stop(); }
  // Hands `c` to a free thread (moved from) and returns true; false, `c` untouched, when none is free.
  bool TryRun(GateConnection& c);
  // Lets every thread finish its request, then joins them.
  void Stop();

 private:
  void Work();

  Serve serve_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<GateConnection> jobs_;
  int idle_ = 0;
  bool stopping_ = false;
  std::vector<std::thread> threads_;
};

// The thread where connections wait for their request header (see above).
class HeaderGate {
 public:
  explicit HeaderGate(GatePool& pool);
  ~HeaderGate() { Stop(); }
  // A connection just accepted (the acceptor's thread), or one back from a response (a pool thread).
  void Admit(int fd);
  void Return(GateConnection c);
  // Closes every waiting connection and joins the thread; what comes back later is closed.
  void Stop();

 private:
  void Loop();
  void TakeInbox();
  void Wait(GateConnection c);
  void CloseOldest(const std::string* address);
  bool Receive(GateConnection& c);  // false: closed or handed on
  void Dispatch(GateConnection& c);
  void Leave(const GateConnection& c);
  void Close(GateConnection& c);

  GatePool& pool_;
  int wake_[2] = {-1, -1};  // a pipe: Admit, Return and Stop wake the poll
  std::mutex mutex_;
  std::vector<GateConnection> inbox_;
  bool stopping_ = false;
  std::vector<GateConnection> waiting_;              // the gate thread's alone
  std::map<std::string, std::size_t> per_address_;  // waiting connections by address
  std::uint64_t next_order_ = 0;
  std::thread thread_;
};

// httplib's server with the gate in front of its request handling.
class GatedServer final : public httplib::Server {
 public:
  // `threads`: the pool (the view: --max-clients streams + 4 for everything else).
  explicit GatedServer(int threads);
  ~GatedServer() override;
  // httplib listens with a backlog of 5: connections arriving faster than the acceptor runs would be
  // dropped by the kernel. Call after bind_to_port.
  void RaiseListenBacklog();

 private:
  class InlineQueue;
  bool process_and_close_socket(socket_t sock) override;  // httplib's hook: the socket goes to the gate
  void Serve(GateConnection c);                           // one request, on a pool thread
  void Shutdown();                                         // httplib's listen loop has ended

  GatePool pool_;
  HeaderGate gate_;
};

}  // namespace lagrange::cli::view
