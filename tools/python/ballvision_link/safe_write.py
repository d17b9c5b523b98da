"""Output files that cannot be half-written or clobber something else (as the C++ tools'
safe_write.cpp): rows go to a temporary file beside the target, commit() flushes, fsyncs and
renames it over the target. Only regular files are replaced; a symlink, FIFO, device or
directory at the target path is refused with an OSError saying so."""
import os
import stat
import tempfile


def check_output_path(path: str) -> None:
    try:
        st = os.lstat(path)
    except FileNotFoundError:
        return
    if stat.S_ISREG(st.st_mode):
        return
    kind = ("a symbolic link" if stat.S_ISLNK(st.st_mode) else
            "a FIFO" if stat.S_ISFIFO(st.st_mode) else
            "a device" if stat.S_ISCHR(st.st_mode) or stat.S_ISBLK(st.st_mode) else
            "a directory" if stat.S_ISDIR(st.st_mode) else "not a regular file")
    raise OSError(f"refusing to write {path}: it is {kind} (only regular files are replaced)")


class SafeOutput:
    def __init__(self, path: str):
        check_output_path(path)
        self.path = path
        d = os.path.dirname(path) or "."
        fd, self.tmp = tempfile.mkstemp(dir=d, prefix="." + os.path.basename(path) + ".")
        mask = os.umask(0)
        os.umask(mask)
        os.fchmod(fd, 0o666 & ~mask)
        self._f = os.fdopen(fd, "w", newline="")

    def write(self, text: str) -> None:
        self._f.write(text)

    def commit(self) -> None:
        try:
            self._f.flush()
            os.fsync(self._f.fileno())
            self._f.close()
            check_output_path(self.path)
            os.replace(self.tmp, self.path)
        except OSError as e:
            self._f.close()
            os.unlink(self.tmp)
            raise OSError(f"{self.path}: {e.strerror or e}; left unchanged") from e
        dfd = os.open(os.path.dirname(self.path) or ".", os.O_RDONLY)
        try:
            os.fsync(dfd)
        finally:
            os.close(dfd)
