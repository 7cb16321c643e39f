"""Posts: one module per controller dialect behind one interface (:class:`base.Post`: ``write`` a
:class:`..machining.toolpath.Program` to text, ``read`` text back to moves), and the read-back of a posted
program (:mod:`.readback`: forward kinematics to rotor-frame poses, sweep simulation, clearance, cycle time).

Dialects: ``linuxcnc`` (rs274ngc), ``fanuc`` (ISO), ``heidenhain`` (Klartext); docs/posts.md.
"""
from .base import PostError, atomic_write
from .fanuc import FanucPost
from .heidenhain import HeidenhainPost
from .linuxcnc import LinuxCNCPost

POSTS = {p.name: p for p in (LinuxCNCPost, FanucPost, HeidenhainPost)}


def get_post(name):
    """A new post of dialect ``name``; :class:`PostError` listing the valid names otherwise."""
    try:
        return POSTS[str(name)]()
    except KeyError:
        raise PostError(f"unknown post {name!r}; valid posts: {', '.join(POSTS)}") from None


def post_for_file(path):
    """The post whose file extension ``path`` has (None if none does)."""
    ext = str(path).lower().rpartition(".")[2]
    for p in POSTS.values():
        if p.extension.lstrip(".") == ext:
            return p()
    return None


def write_program(program, post, path):
    """Write ``program`` with ``post`` (name or :class:`base.Post`) to ``path`` atomically; returns the text."""
    post = get_post(post) if isinstance(post, str) else post
    text = post.write(program)
    atomic_write(path, text)
    return text


__all__ = ["POSTS", "PostError", "get_post", "post_for_file", "write_program", "atomic_write"]
