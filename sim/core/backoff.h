#pragma once
// Retry with exponential backoff, for a device that went away (a serial adapter unplugged, a
// CAN interface down, a V4L2 node removed): the first retry after `first_s`, each failure
// doubling the wait up to `max_s`; a success starts over. Pure arithmetic on times the caller
// passes in (its own clock), so it has no clock of its own and allocates nothing.
//
//   Backoff b(0.1, 5.0);
//   if (lost && b.due(now_s)) { if (reopen() == 0) b.succeeded(); else b.failed(now_s); }

namespace nvs {

class Backoff {
  public:
    constexpr Backoff(double first_s, double max_s) : first_s_(first_s), max_s_(max_s) {}
    // The device was found gone at `now_s`: the first retry is first_s later (once per loss).
    void lost(double now_s) noexcept {
        if (waiting_) return;
        waiting_ = true;
        wait_s_ = first_s_;
        next_s_ = now_s + wait_s_;
    }
    // Is a retry due at `now_s`? (Also true when lost() was never called: retry at once.)
    bool due(double now_s) const noexcept { return !waiting_ || now_s >= next_s_; }
    // The retry at `now_s` failed: wait twice as long (at most max_s) before the next.
    void failed(double now_s) noexcept {
        waiting_ = true;
        wait_s_ = wait_s_ * 2.0 > max_s_ ? max_s_ : wait_s_ * 2.0;
        next_s_ = now_s + wait_s_;
    }
    // The device is back: the next loss starts from first_s again.
    void succeeded() noexcept {
        waiting_ = false;
        wait_s_ = first_s_;
    }
    double wait_s() const noexcept { return wait_s_; }
    double next_s() const noexcept { return next_s_; }

  private:
    double first_s_, max_s_;
    double wait_s_ = first_s_;
    double next_s_ = 0.0;
    bool waiting_ = false;
};

// The backoff nvstim uses for every lost device: 0.1 s, 0.2 s, … up to 5 s between retries.
inline constexpr double kReconnectFirst_s = 0.1;
inline constexpr double kReconnectMax_s = 5.0;

}  // namespace nvs
