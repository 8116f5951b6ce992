// Whole-file I/O for maps and other files the node and the tools write and read: atomic writes
// that survive a kill at any moment, and bounded reads that never block on a FIFO or a device.
#pragma once

#include <cstddef>
#include <string>

#include "multiview_object_detection/pipeline/types/common.h"

namespace mvod {

// Atomic write: a temporary file beside `path` (".<name>.save-<pid>.XXXXXX"), then rename. A
// replaced file keeps its mode (and owner, where the process may set it); the temporaries of `path`
// a killed save left behind are removed first. Concurrent saves to one path (threads or processes)
// each succeed, the last rename wins. Refuses to replace anything but a regular file: a symbolic
// link at `path` is refused naming its target, and neither the link nor its target is touched.
Status writeFileAtomic(const std::string& path, const std::string& content);

// Removes the temporaries of `path` whose process is no longer running (a save killed mid-write);
// never another saver's file in progress, nor any file not named as a save's temporary. Returns
// how many it removed.
int removeOrphanTemporaries(const std::string& path);
// Whole-file read of a regular file of at most max_bytes: a FIFO, device or directory is refused
// at once (never blocks, never reads forever). kRefuse: a symbolic link at `path` is refused too
// (O_NOFOLLOW; the node's map files), kFollow: read what it points to (datasets are often links).
enum class Links { kFollow, kRefuse };
constexpr size_t kDefaultMaxFileBytes = size_t{1} << 30;  // 1 GiB
Status readFile(const std::string& path, std::string* content,
                size_t max_bytes = kDefaultMaxFileBytes, Links links = Links::kFollow);

// What a file of st_mode `mode` is, for a message: "a FIFO", "a directory", ...
std::string fileKindText(unsigned int mode);

// "a symbolic link to <target>" when `path` is a link (not followed), else "" (for messages).
std::string describeLink(const std::string& path);

}  // namespace mvod
