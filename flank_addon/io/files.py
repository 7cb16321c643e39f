"""Writing a file whole or not at all."""
import os
import tempfile


def atomic_write(path, data, encoding="utf-8", newline=None):
    """Write ``data`` (str, or bytes) to ``path`` through a temporary file in the same folder and os.replace,
    so the file is either the old one or the complete new one.  A failure leaves no temporary file and raises
    OSError naming ``path`` (a text that cannot be encoded raises UnicodeEncodeError)."""
    path = os.fspath(path)
    folder = os.path.dirname(os.path.abspath(path))
    try:
        fd, tmp = tempfile.mkstemp(prefix=".flank-", suffix=".tmp", dir=folder)
    except OSError as e:
        raise OSError(e.errno, e.strerror, path) from None
    try:
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
