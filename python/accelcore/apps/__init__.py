"""Applications room: the command line, bulk processing of archives, the demo, the bench runner.

These compose the rooms upstream into jobs; nothing in the library imports them.

May import: every other room.
"""
