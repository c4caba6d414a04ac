#pragma once
// Subscribing member functions through LCM's function subscriptions, for the
// tests that listen with lcm::LCM to well-formed traffic (lagranged and
// lagrangectl receive through protocol/bus.hpp instead).
//
// LCM 1.3.1's member-function subscriptions (LCM::subscribe with a handler
// object) trip UndefinedBehaviorSanitizer's vptr check inside LCM's own
// header, which would hide our own findings in sanitizer runs; its function
// subscriptions are clean. Subscribe<&T::Method>(lcm, channel, object) calls
// object->Method(rbuf, channel) for every message, raw.

#include <lcm/lcm-cpp.hpp>

#include <string>

namespace lagrange {

template <auto Method, class T>
lcm::Subscription* Subscribe(lcm::LCM& lcm, const std::string& channel, T* object) {
  return lcm.subscribeFunction(
      channel, +[](const lcm::ReceiveBuffer* rbuf, const std::string& name, T* self) { (self->*Method)(rbuf, name); },
      object);
}

}  // namespace lagrange
