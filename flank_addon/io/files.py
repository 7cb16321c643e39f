"""Writing a file whole or not at all."""
import os
import tempfile


def output_path_error(path, prefix=False):
    """Why a file cannot be written at ``path`` (relative to the current folder unless absolute), said before any
    work: the path is a folder, or its folder does not exist or is not writable -> a message naming it, or None.
    ``prefix``: ``path`` begins the names of several files (``PREFIX_<k>.stl``), so only its folder is checked."""
    # a prefix names files that begin with it: "out/" is the folder out, "out/strip" the folder out
    path = os.fspath(path)
    path = os.path.abspath(path + "_" if prefix else path)
    folder = os.path.dirname(path)
    if not prefix and os.path.isdir(path):
        return f"{path} is a folder: give a file name"
    if not os.path.isdir(folder):
        if os.path.exists(folder):
            return f"{folder} is not a folder"
        return f"the folder {folder} does not exist"
    if not os.access(folder, os.W_OK):
        return f"the folder {folder} is not writable"
    return None


def atomic_write(path, data, encoding="utf-8", newline=None):
    """Write ``data`` (str, or bytes) to ``path`` through a temporary file in the same folder and os.replace,
    so the file is either the old one or the complete new one (:func:`atomic_write_all` of one file).  A failure
    leaves no temporary file and raises OSError naming ``path``; a text that cannot be encoded raises
    UnicodeEncodeError before any file is made.  Text is written as ``open(path, "w", newline=newline)`` would
    write it, and the file gets the mode such a write gives it: the old file's, or for a new one read/write as
    the umask allows (the temporary file is made private, which would leave programs and plans unreadable to a
    DNC service or a colleague)."""
    if not isinstance(data, bytes):
        if newline is None:
            newline = os.linesep
        if newline not in ("", "\n"):
            data = data.replace("\n", newline)
        data = data.encode(encoding)
    atomic_write_all([(path, data)])


def _mode_for(path):
    """The permission bits a plain ``open(path, "w")`` would leave: the existing file's, else 0o666 less the umask."""
    try:
        return os.stat(path).st_mode & 0o7777
    except OSError:
        pass
    mask = os.umask(0o22)      # the only portable way to read the umask is to set it, and then put it back
    os.umask(mask)
    return 0o666 & ~mask


def atomic_write_all(items):
    """Write several files [(path, bytes)] as one: every one is written to a temporary file in its folder first,
    and only when all of them are complete do they replace their paths, so a failure (a full disk, a folder in
    the way) leaves every earlier file as it was and no temporary file behind.  Raises OSError naming the path."""
    # a symbolic link is written through (its target gets the new file, the link stays: a DNC folder may
    # point at it); anything else that is not a plain file (a folder, a device) is refused, never replaced
    resolved = []
    for path, data in items:
        if os.path.isdir(path):
            raise OSError(21, "Is a directory", os.fspath(path))
        target = os.path.realpath(path)
        if os.path.exists(target) and not os.path.isfile(target):
            raise OSError(22, "not a regular file (a device or socket?)", os.fspath(path))
        resolved.append((target, data))
    items = resolved
    done = []
    try:
        for path, data in items:
            folder = os.path.dirname(os.path.abspath(path))
            try:
                fd, tmp = tempfile.mkstemp(prefix=".flank-", suffix=".tmp", dir=folder)
            except OSError as e:
                raise OSError(e.errno, e.strerror, os.fspath(path)) from None
            done.append((tmp, path))
            try:
                if hasattr(os, "fchmod"):
                    os.fchmod(fd, _mode_for(path))
                with os.fdopen(fd, "wb") as fh:
                    fh.write(data)
            except OSError as e:
                raise OSError(e.errno, e.strerror, os.fspath(path)) from None
        for tmp, path in done:
            try:
                os.replace(tmp, path)
            except OSError as e:        # name the file asked for, not the temporary one
                raise OSError(e.errno, e.strerror, os.fspath(path)) from None
    except BaseException:
        for tmp, _ in done:
            try:
                os.unlink(tmp)
            except OSError:
                pass
        raise
