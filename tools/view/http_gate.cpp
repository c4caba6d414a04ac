#include "tools/view/http_gate.hpp"

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <stdexcept>

namespace lagrange::cli::view {
namespace {

using Clock = std::chrono::steady_clock;

Clock::time_point HeaderDeadline() {
  return Clock::now() + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(kHeaderSeconds));
}

bool HeaderComplete(const std::string& bytes) { return bytes.find("\r\n\r\n") != std::string::npos; }

// The peer's (or with `local`, this end's) address and port.
void AddressOf(int fd, bool local, std::string& ip, int& port) {
  sockaddr_storage address{};
  socklen_t length = sizeof address;
  ip.clear();
  port = 0;
  const int got = local ? getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length)
                        : getpeername(fd, reinterpret_cast<sockaddr*>(&address), &length);
  if (got != 0) return;
  char text[INET6_ADDRSTRLEN] = {};
  if (address.ss_family == AF_INET) {
    const auto* a = reinterpret_cast<const sockaddr_in*>(&address);
    inet_ntop(AF_INET, &a->sin_addr, text, sizeof text);
    port = ntohs(a->sin_port);
  } else if (address.ss_family == AF_INET6) {
    const auto* a = reinterpret_cast<const sockaddr_in6*>(&address);
    inet_ntop(AF_INET6, &a->sin6_addr, text, sizeof text);
    port = ntohs(a->sin6_port);
  }
  ip = text;
}

void CloseSocket(int fd) {
  shutdown(fd, SHUT_RDWR);
  close(fd);
}

// A fixed answer sent without waiting (what the socket takes now), then the connection closed.
void AnswerAndClose(int fd, const char* status, const char* text) {
  const std::string body = std::string("lagrangectl view: ") + text + "\n";
  const std::string reply = std::string("HTTP/1.1 ") + status + "\r\nContent-Type: text/plain\r\nContent-Length: " +
                            std::to_string(body.size()) + "\r\nRetry-After: 1\r\nConnection: close\r\n\r\n" + body;
  [[maybe_unused]] const ssize_t sent = send(fd, reply.data(), reply.size(), MSG_DONTWAIT | MSG_NOSIGNAL);
  shutdown(fd, SHUT_WR);
  close(fd);
}

// What httplib reads and writes one request through: the header the gate read,
// then the end of the stream; writes go to the socket, each within the write timeout.
class GateStream final : public httplib::Stream {
 public:
  GateStream(int fd, std::string header, std::chrono::microseconds write_timeout)
      : fd_(fd), header_(std::move(header)), write_timeout_(write_timeout) {}

  bool is_readable() const override { return at_ < header_.size(); }
  bool is_writable() const override { return WaitWritable(Clock::now() + write_timeout_); }
  ssize_t read(char* ptr, std::size_t size) override {
    if (at_ >= header_.size()) {
      read_past_header_ = true;
      return 0;
    }
    const std::size_t n = std::min(size, header_.size() - at_);
    std::copy_n(header_.data() + at_, n, ptr);
    at_ += n;
    return static_cast<ssize_t>(n);
  }
  // All of it, or −1: httplib writes a response's head in one call and does not retry a short write.
  ssize_t write(const char* ptr, std::size_t size) override {
    const auto deadline = Clock::now() + write_timeout_;
    for (std::size_t done = 0; done < size;) {
      if (!WaitWritable(deadline)) return -1;
      const ssize_t n = send(fd_, ptr + done, size - done, MSG_DONTWAIT | MSG_NOSIGNAL);
      if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return -1;
      if (n > 0) done += static_cast<std::size_t>(n);
    }
    return static_cast<ssize_t>(size);
  }
  void get_remote_ip_and_port(std::string& ip, int& port) const override { AddressOf(fd_, false, ip, port); }
  void get_local_ip_and_port(std::string& ip, int& port) const override { AddressOf(fd_, true, ip, port); }
  socket_t socket() const override { return fd_; }

  bool read_past_header() const { return read_past_header_; }
  std::string Leftover() const { return header_.substr(at_); }  // a pipelined next request's start

 private:
  bool WaitWritable(Clock::time_point deadline) const {
    for (;;) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
      if (left < 0) return false;
      pollfd p{fd_, POLLOUT, 0};
      const int r = poll(&p, 1, static_cast<int>(left));
      if (r > 0) return (p.revents & (POLLERR | POLLHUP | POLLNVAL)) == 0;
      if (r == 0 || errno != EINTR) return false;
    }
  }

  int fd_;
  std::string header_;
  std::size_t at_ = 0;
  bool read_past_header_ = false;
  std::chrono::microseconds write_timeout_;
};

}  // namespace

// ---- the pool ----

GatePool::GatePool(int threads, Serve serve) : serve_(std::move(serve)), idle_(threads) {
  for (int i = 0; i < threads; ++i) threads_.emplace_back([this] { Work(); });
}

bool GatePool::TryRun(GateConnection& c) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || idle_ == 0) return false;
    --idle_;  // taken now, so a second request never counts on the same thread
    jobs_.push_back(std::move(c));
  }
  cv_.notify_one();
  return true;
}

void GatePool::Work() {
  std::unique_lock lock(mutex_);
  for (;;) {
    cv_.wait(lock, [this] { return stopping_ || !jobs_.empty(); });
    if (jobs_.empty()) return;  // stopping, nothing left
    GateConnection c = std::move(jobs_.front());
    jobs_.pop_front();
    lock.unlock();
    serve_(std::move(c));
    lock.lock();
    ++idle_;
  }
}

void GatePool::Stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  for (std::thread& t : threads_) t.join();
  threads_.clear();
}

// ---- the gate ----

HeaderGate::HeaderGate(GatePool& pool) : pool_(pool) {
  if (pipe2(wake_, O_CLOEXEC | O_NONBLOCK) != 0) throw std::runtime_error("pipe failed");
  thread_ = std::thread([this] { Loop(); });
}

void HeaderGate::Admit(int fd) {
  GateConnection c;
  c.fd = fd;
  int port = 0;
  AddressOf(fd, false, c.address, port);
  Return(std::move(c));
}

void HeaderGate::Return(GateConnection c) {
  {
    std::lock_guard lock(mutex_);
    // Bounded here too: the gate thread takes them at once, so only a stalled gate lets it fill.
    if (!stopping_ && inbox_.size() < kMaxWaiting) {
      inbox_.push_back(std::move(c));
      const char byte = 1;
      [[maybe_unused]] const ssize_t n = write(wake_[1], &byte, 1);  // full: a wake-up is pending anyway
      return;
    }
  }
  CloseSocket(c.fd);
}

void HeaderGate::Stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return;
    stopping_ = true;
    const char byte = 1;
    [[maybe_unused]] const ssize_t n = write(wake_[1], &byte, 1);
  }
  thread_.join();
  std::lock_guard lock(mutex_);
  for (GateConnection& c : inbox_) CloseSocket(c.fd);
  inbox_.clear();
  close(wake_[0]);
  close(wake_[1]);
}

// Poll the waiting connections (and the wake-up pipe) until the next header deadline; read what came.
void HeaderGate::Loop() {
  std::vector<pollfd> fds;
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) break;
    }
    TakeInbox();
    auto next = Clock::now() + std::chrono::seconds(1);
    fds.assign(1, pollfd{wake_[0], POLLIN, 0});
    for (const GateConnection& c : waiting_) {
      fds.push_back({c.fd, POLLIN, 0});
      next = std::min(next, c.deadline);
    }
    const auto wait = std::chrono::duration_cast<std::chrono::milliseconds>(next - Clock::now()).count();
    if (poll(fds.data(), fds.size(), static_cast<int>(std::clamp<std::int64_t>(wait + 1, 0, 1000))) < 0 &&
        errno != EINTR)
      break;
    char drain[64];
    while (read(wake_[0], drain, sizeof drain) > 0) continue;
    const auto now = Clock::now();
    std::vector<GateConnection> kept;
    for (std::size_t i = 0; i < waiting_.size(); ++i) {
      GateConnection& c = waiting_[i];
      if (fds[i + 1].revents != 0 && !Receive(c)) continue;
      if (now >= c.deadline) {  // its whole header did not come in time
        Close(c);
        continue;
      }
      kept.push_back(std::move(c));
    }
    waiting_ = std::move(kept);
  }
  for (GateConnection& c : waiting_) Close(c);
  waiting_.clear();
}

void HeaderGate::TakeInbox() {
  std::vector<GateConnection> arrived;
  {
    std::lock_guard lock(mutex_);
    arrived.swap(inbox_);
  }
  for (GateConnection& c : arrived) Wait(std::move(c));
}

// A connection starts waiting for its header: the caps make room first (the oldest goes).
void HeaderGate::Wait(GateConnection c) {
  c.deadline = HeaderDeadline();
  c.order = next_order_++;
  if (HeaderComplete(c.header)) {  // a pipelined request, already read
    Dispatch(c);
    return;
  }
  if (per_address_[c.address] >= kMaxWaitingPerAddress) {
    CloseOldest(&c.address);
  } else if (waiting_.size() >= kMaxWaiting) {
    CloseOldest(nullptr);
  }
  ++per_address_[c.address];
  waiting_.push_back(std::move(c));
}

void HeaderGate::CloseOldest(const std::string* address) {
  auto oldest = waiting_.end();
  for (auto it = waiting_.begin(); it != waiting_.end(); ++it) {
    if ((address == nullptr || it->address == *address) && (oldest == waiting_.end() || it->order < oldest->order))
      oldest = it;
  }
  if (oldest == waiting_.end()) return;
  Close(*oldest);
  waiting_.erase(oldest);
}

// What the connection sent since; false when it is closed or handed to the pool.
bool HeaderGate::Receive(GateConnection& c) {
  char buffer[4096];
  const std::size_t room = kMaxHeaderBytes - c.header.size();
  const ssize_t n = recv(c.fd, buffer, std::min(room, sizeof buffer), MSG_DONTWAIT);
  if (n < 0 && (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR)) return true;
  if (n <= 0) {  // the client closed it, or it failed
    Close(c);
    return false;
  }
  c.header.append(buffer, static_cast<std::size_t>(n));
  if (HeaderComplete(c.header)) {
    Leave(c);
    Dispatch(c);
    return false;
  }
  if (c.header.size() >= kMaxHeaderBytes) {
    Leave(c);
    AnswerAndClose(c.fd, "431 Request Header Fields Too Large", "a request header is at most 16 KiB");
    return false;
  }
  return true;
}

// A complete request: to a free pool thread, or 503 at once.
void HeaderGate::Dispatch(GateConnection& c) {
  if (pool_.TryRun(c)) return;
  AnswerAndClose(c.fd, "503 Service Unavailable", "busy: every thread is serving a request; try again");
}

// It no longer waits: its address's count goes down (and its entry, at zero).
void HeaderGate::Leave(const GateConnection& c) {
  auto it = per_address_.find(c.address);
  if (it != per_address_.end() && --it->second == 0) per_address_.erase(it);
}

void HeaderGate::Close(GateConnection& c) {
  Leave(c);
  CloseSocket(c.fd);
  c.fd = -1;
}

// ---- the server ----

// httplib's listen loop hands each accepted socket to its task queue as a closure calling
// process_and_close_socket; run at once, on the acceptor's thread, that closure gives the socket to the gate.
class GatedServer::InlineQueue final : public httplib::TaskQueue {
 public:
  explicit InlineQueue(GatedServer& server) : server_(server) {}
  void enqueue(std::function<void()> fn) override { fn(); }
  void shutdown() override { server_.Shutdown(); }

 private:
  GatedServer& server_;
};

GatedServer::GatedServer(int threads)
    : pool_(threads, [this](GateConnection c) { Serve(std::move(c)); }), gate_(pool_) {
  new_task_queue = [this] { return new InlineQueue(*this); };
  set_keep_alive_max_count(kMaxRequestsPerConnection);  // what httplib's Keep-Alive header tells browsers
  set_keep_alive_timeout(static_cast<time_t>(kHeaderSeconds));
}

GatedServer::~GatedServer() { Shutdown(); }

void GatedServer::RaiseListenBacklog() { ::listen(svr_sock_, 128); }

bool GatedServer::process_and_close_socket(socket_t sock) {
  gate_.Admit(sock);
  return true;
}

// One request by httplib's own handling. The connection goes back to the gate for the next, unless httplib
// or the client closes it, it read past its header (a body), its method was refused (its body is unread), or
// it has served kMaxRequestsPerConnection.
void GatedServer::Serve(GateConnection c) {
  const bool get = c.header.starts_with("GET ") || c.header.starts_with("HEAD ");
  const bool last = ++c.served >= kMaxRequestsPerConnection || !get;
  GateStream stream(c.fd, std::move(c.header),
                    std::chrono::seconds(write_timeout_sec_) + std::chrono::microseconds(write_timeout_usec_));
  bool closed = false;
  const bool ok = process_request(stream, last, closed, nullptr);
  if (!ok || closed || last || stream.read_past_header()) {
    CloseSocket(c.fd);
    return;
  }
  c.header = stream.Leftover();
  gate_.Return(std::move(c));
}

void GatedServer::Shutdown() {
  gate_.Stop();
  pool_.Stop();
}

}  // namespace lagrange::cli::view
