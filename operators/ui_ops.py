# SPDX-License-Identifier: GPL-3.0-or-later
"""Placeholder: being written (issue 6 panels).  Exposes ``classes`` registered by operators/__init__.py."""
classes = ()
