#pragma once
/// \file
/// Opening a file that must be a regular file: a FIFO, a device, a socket or a directory put at
/// its name by anyone (a results folder, a sweep's journal) must neither block the open nor be
/// read or appended to (docs/security.md, "Untrusted input").

#include <sys/types.h>

#include <string>

namespace multibond {

/// What a file of mode `st_mode` is, for a message: "a FIFO (named pipe)", "a directory", ...
const char* FileKindName(mode_t st_mode);

/// Opens `path` with `flags` (and `mode` for O_CREAT) and O_NONBLOCK, so that a FIFO with no
/// writer or reader cannot block; returns a blocking descriptor when the file is a regular one.
/// Returns -1 with errno set when the open fails; throws std::runtime_error ("'path' is a FIFO
/// (named pipe), not a regular file") when what is there is not a regular file.
int OpenRegularFile(const std::string& path, int flags, mode_t mode = 0);

}  // namespace multibond
