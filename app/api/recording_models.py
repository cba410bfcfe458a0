"""The REST API's recording models (pydantic): a recording in the list (its file and its metadata), the
recorder's status, the bodies that start a recording and change one."""

from pydantic import BaseModel, ConfigDict, Field

from app.recordings.meta import TITLE_MAX_CHARS
from app.recordings.store import RecordingInfo

#: A title: printable text (no control characters), at most TITLE_MAX_CHARS characters.
TITLE_PATTERN = r"^[^\x00-\x1f\x7f]*$"
#: A new file name: RECORDING_NAME, ".viser" optional (added when missing).
NEW_NAME_PATTERN = r"^[A-Za-z0-9][A-Za-z0-9_-]{0,99}(\.viser)?$"


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True)


class RecordingStart(_Strict):
    """Start recording the live scene."""

    label: str = Field(
        "", max_length=40, pattern=r"^[A-Za-z0-9_ -]*$", description="added to the file name (spaces become '-')"
    )
    title: str = Field("", max_length=TITLE_MAX_CHARS, pattern=TITLE_PATTERN, description="shown in the list")


class RecordingChange(_Strict):
    """Rename a recording's file and/or change its title (at least one of the two)."""

    model_config = ConfigDict(json_schema_extra={"minProperties": 1})

    name: str = Field(
        None,
        pattern=NEW_NAME_PATTERN,
        description="the new file name (letters, digits, '_', '-'; '.viser' is added when missing); 409 when "
        "a recording of that name exists",
    )
    title: str = Field(
        None, max_length=TITLE_MAX_CHARS, pattern=TITLE_PATTERN, description="the new title ('' removes it)"
    )


class RecordingEntry(BaseModel):
    """A recording of the recordings folder: its file, where to get and play it, and what it shows (the
    metadata fields are null for a recording without metadata; `metadata_note` then says why)."""

    name: str = Field(description="file name, NAME.viser")
    size_bytes: int = Field(description="file size, bytes")
    modified: float = Field(description="file modification time, Unix time (s)")
    download_url: str = Field(description="the .viser file")
    html_url: str = Field(description="one HTML file that plays the recording anywhere")
    play_url: str = Field(description="the 3D viewer playing the recording")
    track_url: str | None = Field(
        None,
        description="its data track (simulated time, events, plans, velocities: the player's timeline and plots); "
        "null for a recording made before tracks were kept (it plays without them)",
    )
    title: str = Field("", description="the user's title ('' when none: show the name)")
    robot: str | None = Field(None, description="robot name")
    terrain: str | None = Field(None, description="terrain; 'a → b' when it changed while recording")
    gait: str | None = Field(None, description="gait; 'a → b' when it changed while recording")
    planner: str | None = Field(None, description="planner that ran; 'a vs b' in compare mode")
    duration_s: float | None = Field(None, description="simulated time recorded, s")
    frames: int | None = Field(None, description="frames recorded")
    result: str | None = Field(
        None,
        description="how the run stood at the end: 'goal reached', 'fell: <why>', 'error: <what>' or "
        "'stopped' (the recording was stopped while the robot walked)",
    )
    runs: list[str] = Field([], description="the result of every run that ended while recording, in order")
    created: float | None = Field(None, description="when the recording started, Unix time (s)")
    metadata_note: str | None = Field(
        None, description="null when the metadata was read; else why there is none (missing or unreadable)"
    )


def entry_of(info: RecordingInfo) -> RecordingEntry:
    """The API's entry of a recording of the store."""
    url = f"/api/recordings/{info.name}"
    meta = info.meta
    described = {}
    if meta is not None:
        described = {
            "title": meta.title,
            "robot": meta.robot,
            "terrain": meta.terrain,
            "gait": meta.gait,
            "planner": meta.planner,
            "duration_s": meta.duration_s,
            "frames": meta.frames,
            "result": meta.result,
            "runs": list(meta.runs),
            "created": meta.created,
        }
    return RecordingEntry(
        name=info.name,
        size_bytes=info.size_bytes,
        modified=info.modified,
        download_url=url,
        html_url=f"{url}/html",
        play_url=f"/viewer/?playbackPath={url}",
        track_url=f"{url}/track" if info.track else None,
        metadata_note=None if meta is not None else info.meta_note,
        **described,
    )


class RecordingStatus(BaseModel):
    """The live recorder."""

    recording: bool = Field(
        description="a recording is in progress, or stopped but not saved yet (save_error says why; stop again to "
        "save it)"
    )
    name: str | None = Field(description="file name of the recording in progress")
    frames: int = Field(description="frames recorded so far")
    duration_s: float = Field(description="simulated time recorded so far, s")
    last_saved: str | None = Field(description="file name of the last recording saved")
    save_error: str | None = Field(
        None,
        description="null, or why the recording could not be saved (it is kept: stop again) or its journal "
        "cannot be written (a crash of the tool would lose it)",
    )
