"""The panels of the viser control panel, one class per folder (`app/viewer/gui.py` composes them).

Every control only submits a command to the live session (never waits for it); each panel's
`refresh(view)` (called by the viewer's update loop a few times a second) writes the session's state
back, so changes made through REST or by another browser show up too.
"""
