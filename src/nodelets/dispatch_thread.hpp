// A nodelet's own input thread: it serves a callback queue that the nodelet's input subscriptions
// use, and between messages runs the nodelet's timed work (the Estimator's deadlines, the
// LossyChannel's delayed deliveries).
//
// Why: through the nodelet manager a message costs two thread hand-offs (the manager's dispatch
// thread, then one of its workers), and a separate deadline thread woke once per step even when
// the messages had already completed it. Here a message costs one hand-off (roscpp's receive
// thread, or an in-process publisher, to this thread), and the timed work is the timeout of the
// same wait: it wakes the thread only when a deadline passes with no message before it.
//
// DirectQueue goes one step further for in-process publishers: their messages are handled in the
// publisher's own thread, as a function call, with no hand-off at all (messages from other
// processes still go to the dispatch thread: roscpp's receive thread must not run them, see there).
// ReceiveThreadQueue is its mirror, for a subscriber whose callback publishes nothing (the
// Estimator's inputs, whose steps' outputs the dispatch thread publishes): messages from other
// processes are handled in roscpp's receive thread, with no hand-off at all, and in-process
// publishers' go to the dispatch thread.
#pragma once

#include <ros/callback_queue.h>
#include <pthread.h>
#include <ros/poll_manager.h>

#include <chrono>
#include <mutex>

#include <algorithm>
#include <atomic>
#include <functional>
#include <thread>

namespace networked_estimation
{

/// Whether the calling thread is roscpp's receive (poll) thread. Learnt from the poll loop itself,
/// which calls its listeners on every turn; the first call waits (at most a second) for one turn,
/// so make it where no roscpp lock is held (DispatchThread::directQueue, from a nodelet's onInit).
inline bool inRoscppPollThread()
{
  static std::atomic<std::thread::id> poll_thread{std::thread::id()};
  static std::once_flag once;
  std::call_once(
      once,
      []
      {
        ros::PollManager::instance()->addPollThreadListener([] { poll_thread = std::this_thread::get_id(); });
        ros::PollManager::instance()->getPollSet().signal();  // a turn now, not within 100 ms
        const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(1);
        while (poll_thread.load() == std::thread::id() && std::chrono::steady_clock::now() < until)
          std::this_thread::sleep_for(std::chrono::microseconds(100));
      });
  return std::this_thread::get_id() == poll_thread.load();
}

/// Calls a queued callback now, in this thread (TryAgain only comes from a subscription without
/// concurrent callbacks that another thread is in: wait for that call).
inline void callNow(const ros::CallbackInterfacePtr& callback)
{
  while (callback->call() == ros::CallbackInterface::TryAgain)
    std::this_thread::yield();
}

/// A callback queue that calls every callback at once in the delivering thread, roscpp's receive
/// thread included. Only for callbacks that publish nothing and take no lock that a publishing
/// thread may hold (BenchNullReceiver's ~inline, SimClockWatch's ticks, the Estimator's /tf
/// readers): roscpp's receive thread holds the subscription's lock while it delivers.
class InlineQueue : public ros::CallbackQueueInterface
{
public:
  void addCallback(const ros::CallbackInterfacePtr& callback, uint64_t) override { callNow(callback); }
  void removeByID(uint64_t) override {}
};

/// A callback queue that calls a subscription's callback at once in the thread that delivers the
/// message, for one kind of delivering thread (`Inline`), and sends the others' deliveries to
/// `queued`. DirectQueue and ReceiveThreadQueue below are its two kinds.
class SplitQueue : public ros::CallbackQueueInterface
{
public:
  enum class Inline
  {
    IN_PROCESS_PUBLISHER,   ///< any thread but roscpp's receive thread
    ROSCPP_RECEIVE_THREAD,  ///< roscpp's receive thread only
  };
  SplitQueue(ros::CallbackQueueInterface* queued, Inline which) : queued_(queued), which_(which) {}

  void addCallback(const ros::CallbackInterfacePtr& callback, uint64_t owner_id) override
  {
    if (inRoscppPollThread() != (which_ == Inline::ROSCPP_RECEIVE_THREAD))
    {
      queued_->addCallback(callback, owner_id);
      return;
    }
    callNow(callback);
  }

  void removeByID(uint64_t owner_id) override { queued_->removeByID(owner_id); }

private:
  ros::CallbackQueueInterface* queued_;
  Inline which_;
};

/// A callback queue that calls a subscription's callback at once, in the thread that delivers the
/// message: an in-process publisher's thread (no hand-off). Deliveries by roscpp's receive thread
/// go to `queued` instead. That thread holds the subscription's lock while it delivers; were it to
/// run a callback that publishes, it would wait for roscpp's publication lock while an in-process
/// publisher to the same topic holds that lock and waits for the subscription's: a deadlock.
///
/// What a subscriber on a DirectQueue must do, because its callback runs inside roscpp's publish
/// (with roscpp's global publication lock held): subscribe with allow_concurrent_callbacks (two
/// publishers' threads may call it at once), and never publish while holding a lock that its
/// callback also takes (another thread holding it would wait for the publication lock).
class DirectQueue : public SplitQueue
{
public:
  explicit DirectQueue(ros::CallbackQueueInterface* queued) : SplitQueue(queued, Inline::IN_PROCESS_PUBLISHER) {}
};

/// The mirror of DirectQueue: a callback queue that calls a subscription's callback at once in
/// roscpp's receive thread, when that thread delivers it (a message from another process: no
/// hand-off at all), and sends an in-process publisher's deliveries to `queued` (that publisher
/// holds roscpp's global publication lock while it delivers: its publish stays short).
///
/// What a subscriber on a ReceiveThreadQueue must do: what InlineQueue asks. Its callback
/// publishes nothing, and takes no lock that a thread may hold while it publishes: roscpp's
/// receive thread holds the subscription's lock while it delivers, and an in-process publisher to
/// the same topic takes roscpp's publication lock and then the subscription's.
class ReceiveThreadQueue : public SplitQueue
{
public:
  explicit ReceiveThreadQueue(ros::CallbackQueueInterface* queued) : SplitQueue(queued, Inline::ROSCPP_RECEIVE_THREAD)
  {
  }
};

class DispatchThread
{
public:
  DispatchThread() = default;
  DispatchThread(const DispatchThread&) = delete;
  DispatchThread& operator=(const DispatchThread&) = delete;
  ~DispatchThread() { stop(); }

  /// The queue to give the input subscriptions (NodeHandle::setCallbackQueue).
  ros::CallbackQueue* queue() { return &queue_; }

  /// In-process publishers' messages handled in their thread, the others on this one (DirectQueue).
  /// Call it where no roscpp lock is held (a nodelet's onInit): it learns roscpp's receive thread.
  ros::CallbackQueueInterface* directQueue()
  {
    inRoscppPollThread();
    return &direct_;
  }

  /// Messages from other processes handled in roscpp's receive thread, the others on this one
  /// (ReceiveThreadQueue). Call it where no roscpp lock is held (a nodelet's onInit).
  ros::CallbackQueueInterface* receiveThreadQueue()
  {
    inRoscppPollThread();
    return &receive_;
  }

  /// Whether the caller is this thread (work() runs after its callbacks: no wake() needed).
  bool inThisThread() const { return std::this_thread::get_id() == thread_.get_id(); }

  /// Starts the thread. `work` runs the timed work that is due (taking its own locks) and returns
  /// the wall seconds until it is next due (0: at once; infinity: nothing timed). It runs after
  /// every batch of callbacks and whenever that time has passed without a message. The thread is
  /// named kName, so that top -H, perf and the benchmarks' per-thread tables tell it from
  /// roscpp's threads (which carry the process's name).
  void start(std::function<double()> work)
  {
    work_ = std::move(work);
    thread_ = std::thread([this] { run(); });
    pthread_setname_np(thread_.native_handle(), kName);  // best effort: a name is only a label
  }

  /// The thread's name (at most 15 characters: Linux's limit).
  static constexpr const char* kName = "ne_dispatch";

  /// Makes the thread run `work` now (after a change made by another thread, e.g. a reconfigure).
  void wake() { queue_.addCallback(boost::make_shared<Nothing>()); }

  /// Stops and joins the thread (callbacks still queued are not called). Idempotent.
  void stop()
  {
    if (!thread_.joinable())
      return;
    stop_ = true;
    wake();
    thread_.join();
  }

private:
  struct Nothing : ros::CallbackInterface
  {
    CallResult call() override { return Success; }
  };

  void run()
  {
    while (!stop_)
    {
      const double wait = work_();
      if (stop_)
        break;
      // At most a second: a bounded wait, whatever the work says.
      queue_.callAvailable(ros::WallDuration(std::max(0.0, std::min(wait, 1.0))));
    }
  }

  ros::CallbackQueue queue_;
  DirectQueue direct_{&queue_};
  ReceiveThreadQueue receive_{&queue_};
  std::function<double()> work_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

}  // namespace networked_estimation
