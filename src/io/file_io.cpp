#include "multiview_object_detection/io/file_io.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <vector>

namespace mvod {

namespace {

// A save's temporary beside `name`: ".<name>.save-<pid>.XXXXXX". The dot keeps it out of listings;
// the process id says whose it is, so a save removes only what a dead process left behind, never
// another saver's file in progress or a user's file.
std::string temporaryPrefix(const std::string& name) { return "." + name + ".save-"; }

// `path`, known to be a link, for a message.
std::string linkText(const std::string& path) {
  const std::string described = describeLink(path);
  return described.empty() ? "a symbolic link" : described;
}

bool processAlive(long pid) {
  if (pid <= 0 || pid > INT32_MAX) return false;
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

}  // namespace

int removeOrphanTemporaries(const std::string& path) {
  const size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : path.substr(0, slash == 0 ? 1 : slash);
  const std::string prefix =
      temporaryPrefix(slash == std::string::npos ? path : path.substr(slash + 1));
  int removed = 0;
  std::error_code error;
  for (std::filesystem::directory_iterator it(dir, error), end; !error && it != end;
       it.increment(error)) {
    const std::string entry = it->path().filename().string();
    if (entry.compare(0, prefix.size(), prefix) != 0) continue;
    // "<pid>.XXXXXX" after the prefix.
    const std::string rest = entry.substr(prefix.size());
    const size_t dot = rest.find('.');
    if (dot == std::string::npos || dot == 0 || rest.size() != dot + 7 ||
        rest.find_first_not_of("0123456789") != dot) {
      continue;
    }
    const long pid = std::strtol(rest.substr(0, dot).c_str(), nullptr, 10);
    std::error_code file_error;
    if (processAlive(pid) || !it->is_regular_file(file_error)) continue;
    if (std::filesystem::remove(it->path(), file_error)) ++removed;
  }
  return removed;
}

Status writeFileAtomic(const std::string& path, const std::string& content) {
  // The temporary lives in the target's folder so rename() stays on one filesystem (atomic).
  const size_t slash = path.find_last_of('/');
  const std::string dir = slash == std::string::npos ? "." : path.substr(0, slash == 0 ? 1 : slash);
  const std::string name = slash == std::string::npos ? path : path.substr(slash + 1);
  if (name.empty()) return Status::Error("cannot write " + path + ": no file name");
  // lstat: a link at `path` is reported as one, never followed (its target is not ours to replace).
  struct stat existing {};
  const bool replacing = ::lstat(path.c_str(), &existing) == 0;
  if (replacing && S_ISLNK(existing.st_mode)) {
    return Status::Error("cannot write " + path + ": it is " + linkText(path) +
                         "; no file is written through a link, nor a link replaced: give the "
                         "path of the file itself");
  }
  if (replacing && !S_ISREG(existing.st_mode)) {
    return Status::Error("cannot write " + path + ": it exists and is not a regular file");
  }
  removeOrphanTemporaries(path);
  std::string tmp_path = (dir == "/" ? "" : dir) + "/" + temporaryPrefix(name) +
                         std::to_string(::getpid()) + ".XXXXXX";
  std::vector<char> tmp_name(tmp_path.begin(), tmp_path.end());
  tmp_name.push_back('\0');
  const int fd = ::mkstemp(tmp_name.data());
  if (fd < 0) {
    return Status::Error("cannot create a temporary file next to " + path + ": " +
                         std::strerror(errno));
  }
  tmp_path = tmp_name.data();
  auto fail = [&](const std::string& what) {
    const std::string message = what + " " + tmp_path + ": " + std::strerror(errno);
    ::close(fd);
    ::unlink(tmp_path.c_str());
    return Status::Error(message);
  };
  size_t written = 0;
  while (written < content.size()) {
    const ssize_t n = ::write(fd, content.data() + written, content.size() - written);
    if (n < 0) {
      if (errno == EINTR) continue;
      return fail("cannot write");
    }
    written += static_cast<size_t>(n);
  }
  // mkstemp creates 0600: a replaced file keeps its mode, a new one gets the usual permissions.
  // The owner first (where allowed: root, or the same owner), as a change of owner clears the
  // set-id bits; a failure leaves the file the saver's, as any new file is.
  if (replacing) {
    if (::fchown(fd, existing.st_uid, existing.st_gid) != 0) errno = 0;
    ::fchmod(fd, existing.st_mode & 07777);
  } else {
    const mode_t mask = ::umask(0);
    ::umask(mask);
    ::fchmod(fd, 0666 & ~mask);
  }
  if (::fsync(fd) != 0) return fail("cannot fsync");
  if (::close(fd) != 0) {
    const std::string message = "cannot close " + tmp_path + ": " + std::strerror(errno);
    ::unlink(tmp_path.c_str());
    return Status::Error(message);
  }
  if (::rename(tmp_path.c_str(), path.c_str()) != 0) {
    const std::string message =
        "cannot rename " + tmp_path + " to " + path + ": " + std::strerror(errno);
    ::unlink(tmp_path.c_str());
    return Status::Error(message);
  }
  // Make the rename itself durable.
  const int dir_fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY);
  if (dir_fd >= 0) {
    ::fsync(dir_fd);
    ::close(dir_fd);
  }
  return Status::Ok();
}

std::string fileKindText(unsigned int mode) {
  return S_ISREG(mode)    ? "a regular file"
         : S_ISDIR(mode)  ? "a directory"
         : S_ISFIFO(mode) ? "a FIFO"
         : S_ISCHR(mode)  ? "a character device"
         : S_ISBLK(mode)  ? "a block device"
         : S_ISSOCK(mode) ? "a socket"
         : S_ISLNK(mode)  ? "a symbolic link"
                          : "not a regular file";
}

std::string describeLink(const std::string& path) {
  std::error_code error;
  const std::filesystem::path target = std::filesystem::read_symlink(path, error);
  if (error) return "";
  return "a symbolic link to " + target.string();
}

Status readFile(const std::string& path, std::string* content, size_t max_bytes, Links links) {
  // O_NONBLOCK: opening a FIFO must not wait for a writer; only regular files are read.
  const int fd = ::open(
      path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC | (links == Links::kRefuse ? O_NOFOLLOW : 0));
  if (fd < 0 && errno == ELOOP && links == Links::kRefuse) {
    return Status::Error("cannot read " + path + ": it is " + linkText(path) +
                         "; read by its own path only, never through a link");
  }
  if (fd < 0) return Status::Error("cannot open " + path + ": " + std::strerror(errno));
  struct stat info {};
  if (::fstat(fd, &info) != 0) {
    const std::string message = "cannot stat " + path + ": " + std::strerror(errno);
    ::close(fd);
    return Status::Error(message);
  }
  if (!S_ISREG(info.st_mode)) {
    ::close(fd);
    return Status::Error("cannot read " + path + ": it is " + fileKindText(info.st_mode) +
                         ", not a regular file");
  }
  if (static_cast<unsigned long long>(info.st_size) > max_bytes) {
    ::close(fd);
    return Status::Error("cannot read " + path + ": " + std::to_string(info.st_size) +
                         " bytes, more than the limit of " + std::to_string(max_bytes));
  }
  std::string data;
  data.resize(static_cast<size_t>(info.st_size));
  size_t done = 0;
  while (true) {
    if (done == data.size()) {
      // The file may have grown since fstat; read on, within the limit.
      if (data.size() >= max_bytes) {
        char probe;
        const ssize_t n = ::read(fd, &probe, 1);
        if (n > 0) {
          ::close(fd);
          return Status::Error("cannot read " + path + ": more than the limit of " +
                               std::to_string(max_bytes) + " bytes");
        }
        break;
      }
      data.resize(std::min(max_bytes, data.size() + 65536));
    }
    const ssize_t n = ::read(fd, &data[done], data.size() - done);
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      const std::string message = "cannot read " + path + ": " + std::strerror(errno);
      ::close(fd);
      return Status::Error(message);
    }
    if (n == 0) break;
    done += static_cast<size_t>(n);
  }
  ::close(fd);
  data.resize(done);
  *content = std::move(data);
  return Status::Ok();
}

}  // namespace mvod
