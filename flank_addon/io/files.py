"""Writing a file whole or not at all."""
import os
import tempfile


def atomic_write(path, data, encoding="utf-8", newline=None):
    """Write ``data`` (str, or bytes) to ``path`` through a temporary file in the same folder and os.replace,
    so the file is either the old one or the complete new one.  A failure leaves no temporary file and raises
    OSError naming ``path`` (a text that cannot be encoded raises UnicodeEncodeError).  The file gets the mode an
    ordinary write would give it: the old file's, or for a new one read/write as the umask allows (the temporary
    file is made private, which would leave programs and plans unreadable to a DNC service or a colleague)."""
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    try:
        fd, tmp = tempfile.mkstemp(prefix=".flank-", suffix=".tmp", dir=folder)
    except OSError as e:
        raise OSError(e.errno, e.strerror, path) from None
    try:
        if hasattr(os, "fchmod"):
            os.fchmod(fd, _mode_for(path))
        if isinstance(data, bytes):
            with os.fdopen(fd, "wb") as fh:
                fh.write(data)
        else:
            with os.fdopen(fd, "w", encoding=encoding, newline=newline) as fh:
                fh.write(data)
        os.replace(tmp, path)
    except BaseException as e:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        if isinstance(e, OSError):       # name the file asked for, not the temporary one
            raise OSError(e.errno, e.strerror, path) from None
        raise


def _mode_for(path):
    """The permission bits a plain ``open(path, "w")`` would leave: the existing file's, else 0o666 less the umask."""
    try:
        return os.stat(path).st_mode & 0o7777
    except OSError:
        pass
    mask = os.umask(0o22)      # the only portable way to read the umask is to set it, and then put it back
    os.umask(mask)
    return 0o666 & ~mask
