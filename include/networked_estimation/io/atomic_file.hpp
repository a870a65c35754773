// An output file written to a temporary name and renamed over the target when complete, so that
// no tool ever leaves a partial file behind.
#pragma once

#include <fstream>
#include <string>

namespace networked_estimation
{

/// Writes to `<path>.tmp.<pid>` in the target's directory; commit() flushes and renames it over
/// the target. The destructor removes the temporary file unless commit() succeeded, so the target
/// is either untouched or complete.
class AtomicFile
{
public:
  /// Opens the temporary file. Throws InputError naming the path when it cannot be created.
  explicit AtomicFile(const std::string& path);
  ~AtomicFile();
  AtomicFile(const AtomicFile&) = delete;
  AtomicFile& operator=(const AtomicFile&) = delete;

  std::ostream& stream() { return out_; }
  /// Flushes, closes and renames the temporary file over the target. Throws InputError when the
  /// data could not be written or the rename failed (the temporary file is then removed).
  void commit();

  const std::string& path() const { return path_; }
  const std::string& tempPath() const { return temp_; }
  bool committed() const { return committed_; }

private:
  std::string path_, temp_;
  std::ofstream out_;
  bool committed_ = false;
};

}  // namespace networked_estimation
