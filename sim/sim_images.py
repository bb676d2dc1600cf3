"""Image files from rendered frames: a labelled contact sheet (PNG), a GIF or an MP4, each
written beside its path and renamed into place.

It knows nothing about MuJoCo: frames arrive as RGB arrays.
"""

import os
import sys


def labelled(image, label):
    from PIL import Image, ImageDraw, ImageFont

    picture = Image.fromarray(image)
    if not label:
        return picture
    draw = ImageDraw.Draw(picture, "RGBA")
    size = max(10, picture.height // 16)
    try:
        font = ImageFont.load_default(size=size)
    except TypeError:  # Pillow < 10.1 has only the fixed bitmap font
        font = ImageFont.load_default()
    left, top, right, bottom = draw.textbbox((4, 3), label, font=font)
    draw.rectangle((0, 0, right + 4, bottom + 3), fill=(0, 0, 0, 160))
    draw.text((4, 3), label, fill=(255, 255, 255, 255), font=font)
    return picture


def _pictures(images):
    from PIL import Image

    return [image if isinstance(image, Image.Image) else Image.fromarray(image) for image in images]


def _partial(path):
    # Written beside and renamed, so that nobody ever sees half a file under the real name.
    head, tail = os.path.split(os.path.abspath(path))
    return os.path.join(head, f".{tail}.{os.getpid()}.partial{os.path.splitext(tail)[1]}")


def _finish(partial, path):
    try:
        os.replace(partial, path)
    except OSError:
        _remove(partial)
        raise


def _remove(path):
    try:
        os.remove(path)
    except OSError:
        pass


def write_sheet(images, columns, path):
    from PIL import Image

    pictures = _pictures(images)
    width, height = pictures[0].size
    columns = min(columns, len(pictures))
    rows = (len(pictures) + columns - 1) // columns
    sheet = Image.new("RGB", (columns * width, rows * height), (32, 32, 32))
    for index, picture in enumerate(pictures):
        sheet.paste(picture, ((index % columns) * width, (index // columns) * height))
    partial = _partial(path)
    try:
        sheet.save(partial, format="PNG")
    except Exception:
        _remove(partial)
        raise
    _finish(partial, path)
    return {"columns": columns, "rows": rows, "width": sheet.width, "height": sheet.height}


def write_gif(images, fps, path):
    pictures = _pictures(images)
    partial = _partial(path)
    try:
        pictures[0].save(
            partial,
            format="GIF",
            save_all=True,
            append_images=pictures[1:],
            duration=max(10, int(round(1000.0 / fps))),
            loop=0,
        )
    except Exception:
        _remove(partial)
        raise
    _finish(partial, path)


def write_mp4(images, fps, path):
    import imageio_ffmpeg

    np = sys.modules["numpy"]
    height, width = np.asarray(images[0]).shape[:2]
    partial = _partial(path)
    try:
        writer = imageio_ffmpeg.write_frames(
            partial,
            (width, height),
            fps=fps,
            codec="libx264",
            pix_fmt_in="rgb24",
            pix_fmt_out="yuv420p",
            macro_block_size=1,
            ffmpeg_log_level="error",
        )
        writer.send(None)
        for image in images:
            writer.send(np.ascontiguousarray(np.asarray(image), dtype=np.uint8))
        writer.close()
    except Exception:
        _remove(partial)
        raise
    _finish(partial, path)
