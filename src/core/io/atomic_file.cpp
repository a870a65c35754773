// An output file that is either untouched or complete.
#include "networked_estimation/io/atomic_file.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "networked_estimation/common/error.hpp"

namespace networked_estimation
{

AtomicFile::AtomicFile(const std::string& path)
  : path_(path), temp_(path + ".tmp." + std::to_string(static_cast<long>(::getpid())))
{
  out_.open(temp_, std::ios::out | std::ios::trunc | std::ios::binary);
  if (!out_)
    throw InputError(path_ + ": cannot create output file (" + std::strerror(errno) + ")");
}

AtomicFile::~AtomicFile()
{
  if (!committed_)
  {
    if (out_.is_open())
      out_.close();
    std::remove(temp_.c_str());
  }
}

void AtomicFile::commit()
{
  if (committed_)
    return;
  out_.flush();
  const bool written = static_cast<bool>(out_);
  out_.close();
  if (!written || out_.fail())
  {
    std::remove(temp_.c_str());
    throw InputError(path_ + ": cannot write output file (disk full or I/O error)");
  }
  if (std::rename(temp_.c_str(), path_.c_str()) != 0)
  {
    const std::string reason = std::strerror(errno);
    std::remove(temp_.c_str());
    throw InputError(path_ + ": cannot create output file (" + reason + ")");
  }
  committed_ = true;
}

}  // namespace networked_estimation
