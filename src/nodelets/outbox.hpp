// Messages published in the order they were made, by whichever thread may publish, never with a
// lock held that an input callback takes.
//
// Why: an input callback may run inside roscpp's publish (an in-process publisher's thread, which
// holds roscpp's publication lock, see dispatch_thread.hpp) or inside roscpp's delivery of a message
// (its receive thread, which holds the subscription's lock). Such a callback takes the nodelet's
// lock; a thread that held that lock while it published would wait for the publication lock the
// other holds: a deadlock. So the nodelet pushes what it made into the outbox under its own lock,
// and publishes after releasing it (flush), or leaves it to a thread that may (PollTurnHook).
#pragma once

#include <functional>
#include <mutex>
#include <utility>
#include <vector>

namespace networked_estimation
{

template <class T>
class Outbox
{
public:
  explicit Outbox(std::function<void(const T&)> publish) : publish_(std::move(publish)) {}

  /// Queues one message (push under the lock that orders the messages: they leave in push order).
  void push(T item)
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    items_.push_back(std::move(item));
  }

  /// Queues these messages, in their order, and empties `items`.
  void append(std::vector<T>& items)
  {
    std::lock_guard<std::mutex> lock(queue_mutex_);
    for (T& item : items)
      items_.push_back(std::move(item));
    items.clear();
  }

  /// Publishes every queued message, in order. One thread publishes at a time; a thread that
  /// finds another publishing leaves its messages to it (which looks again before it stops), so
  /// that a thread inside roscpp's publish never waits here for one that waits for roscpp.
  void flush()
  {
    for (;;)
    {
      std::unique_lock<std::mutex> publishing(publishing_, std::try_to_lock);
      if (!publishing.owns_lock())
        return;
      for (;;)
      {
        {
          std::lock_guard<std::mutex> lock(queue_mutex_);
          sending_.swap(items_);
        }
        if (sending_.empty())
          break;
        for (const T& item : sending_)
          publish_(item);
        sending_.clear();
      }
      publishing.unlock();
      std::lock_guard<std::mutex> lock(queue_mutex_);  // pushed after our last look, while we still published?
      if (items_.empty())
        return;
    }
  }

private:
  std::function<void(const T&)> publish_;
  std::mutex queue_mutex_;  ///< items_
  std::vector<T> items_;
  std::mutex publishing_;  ///< held by the one thread that publishes (sending_)
  std::vector<T> sending_;
};

}  // namespace networked_estimation
