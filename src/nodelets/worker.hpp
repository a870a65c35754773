// Stopping a nodelet's background thread: set the stop flag under the mutex the thread waits
// with, wake it, join it. Used by the nodelets' destructors.
#pragma once

#include <condition_variable>
#include <mutex>
#include <thread>

namespace networked_estimation
{

inline void stopWorker(std::mutex& mutex, bool& stop, std::condition_variable& wake, std::thread& thread)
{
  {
    std::lock_guard<std::mutex> lock(mutex);
    stop = true;
  }
  wake.notify_all();
  if (thread.joinable())
    thread.join();
}

}  // namespace networked_estimation
