"""The aruco tracker reads small markers OpenCV's decoder rejected again (:mod:`.rescue`)."""

import base64

import cv2
import numpy as np

from armtree.api.rig import Frame
from armtree.plugins.trackers import synthetic as syn
from armtree.plugins.trackers.aruco import ArucoTracker
from armtree.plugins.trackers.dictionaries import get_dictionary
from armtree.plugins.trackers.rescue import Rescuer

#: 60 x 60 px of a sim_vicra frame (PNG): Durovic 2017's target marker (id 9, 25 mm) 650 mm
#: under the camera, 22 px wide, which OpenCV's decoder rejected in every frame there.
SMALL_TARGET = (
    "iVBORw0KGgoAAAANSUhEUgAAADwAAAA8CAAAAAAfl4auAAAI50lEQVRIDQ3BTa+e11UG4Ptea+/nfW2nVfOBc86x"
    "mwlzJCZMUJxjm4JEJaS2IAbwAxjwC0BiEhUhUAhpEsdOBEICJoQRIIHUJk7TpMFBMORjwITm+CNBShz7nPd99l5r"
    "3fS6eNPhtXKVLJuht1aGXGMKLpxrag5lzgFBS+stjcqcSIi3HJD2lQWz7tyGCVNjQmRHc1pnjEiJuTgXgFnYWWHw"
    "TStTxmDBauOuDqZqr0or25p1bCb2c/pobNyKMs5IpQ++SYIjZspo1ps5aGe196rs4NKse82RIQsu7qC1iMhJgrea"
    "LGtMmVC9NbdcMmNUUbG0xt4FrTGlbHRbDIaIzFLxVsumGVqNwd6cTp+ajJm9lmrebKncZ2W4vPcGtcwaJSVvdLTM"
    "GiiUsZvR0XeaUSxztO4un3NEW9GsszmWOWdGevGN1ko5ssKjdTq7ozLm9FDXwsWciDWjBDad91zA1U6rQN4iWs1J"
    "5CC6L3ArDs6EZqcv5vKaGZiisW3ocq0TA2V8S7TAzJAnvLXN7J6jct8S7uxcyhEjSyXrXAxsFbFXQHxT9IqsRApL"
    "p1lXakSyWN27yS1rqCpZbYsG96m9kuG8aS18RWRV9mat0RMYURqtdZoZDQMjJHXahkZM1ZpU8MZinIoJVG29ES6q"
    "wqbo6eqwolUWkaTRTDJFagSSfy6KGath9qdOM+jTzadPc4WxQCt45pJgNuR5QwuNCLJ4ywnWrjh8+fk+RdpwUsm5"
    "MGujqnKZ5LJp+B9BzMpZNsG3pG3uPbLq/PMX6ZVNyFYGomRpLHK6l9RT8+PTSKJGViB509UQsyLa9vhiE10FZCua"
    "iYWkZ/aUltkz487jKWrUqGTwDaepIlR17oVLAJrk6xYB9YQpe1JlnrKi4vZYS76vKITzZk9DjCphe3zYssVSgheJ"
    "6TJIMEubDUlqfvA4i5qjhmnyzbQlYyp83R4/hwbU/0XJyogUDeUeUvenjdLuzsMMMuZginyj0VSjpvKJK5cMrk9/"
    "4z4gV+VGkCgSpqfevgjD+tHjPVkxM1XiTdKwbztZnLt6cZv0kxfuQwYRlqAsYUy7/M5FAetH+3XQs/b6Kd5s8CjE"
    "3sYT1w4c4Mn1E/Qs9qdbtcnaPxSJw9sHQsUHZ3sCORKV4i0vL66KyQvHh1bG+8/f9yLq0ttPgVZnf//SI8Gf/eGR"
    "gMd3TocKGCEkeJNYMrD6inPXnnU13bt6FxJ1dPsITK5/+eIjQl///oFpjo93++w1M7Uy+UaDc/V91vzalZ9xebt3"
    "fIKf0nP//JzGsP3fvfSQp7j0/UuCdv8SjwChYhYmX9uqRypr6Cu/eOSkPnv+rqcXjn5wGP/+X5GfPxxn/3D2zHuX"
    "gdp/eJrhFag90vg6FreRysDm+MDLdf/qPSsAl35wePbK33y5/fbvPvHg1z597p+OHNp9+DgFG6qZWPla14IBzZqb"
    "60dO1KdXP4EDOHzn0hd//Bdn537rD57532snl989HI2nH52NNB+ZHNjzrbEQGj5Cm2uHDton1+9SbnjuH4++/JO/"
    "frz57d+78NkL9w7eP5rLGB89GmhTocqcfMMNrNDMfOL5y7AW947vyy7/7ObJP3rq7O13d5urv3n+5BsnR+9eHi13"
    "//po18tGZfg6eRNm0M6xx+bqITrs5OpJa9/8/afbVwun+5b9q7j7jU8uv3cRVfnhlwPGUYHKyZu0Hpq2IperB41W"
    "D679BE9858WvWguLJtDmg+ufHL574NTuzqMdwMDKWsnXNkZVZDC2xwdLCQ+u3uO5b//h1wwV6xcE4Pd//cGl24dJ"
    "jB/td3JkDmkG37DWZiqmtL1y1LLr3rV79ZVvvfiklvji1tuPLdTm53nx9qGrdh+f7aKjhjJj8k2qCZkra3N8YAbe"
    "vX7iy3e++6SAh392Yy86xDi8fSRid+fRLFoo5izyhrsrsa+SX7+sBvzkl09w4Zsvnjfi89f/6pEMAuvyO4f0OP3x"
    "OGPTtL3vqvi6LRbMiVEXrly23ORnL5wAP/er25Tt3/+3FTJ56eCHBw159vHjMzQOZdQgX13MmHYm1ebKJcsNTo7v"
    "V7NzQFmtpSTI5NHtQ7UR7z8ONSkyS8Ub2sIwNLPOP3/Ys9Unv/IJwGqpngJFZkse3j6gND/YPyI9Kwoz+BoX9ayc"
    "ic3xpWrwu9/6jwJgJcpYoGBph+8dzKb9B+OszKoUs5KveluSo7Jye/xslzH/83cetPQU50YiLawMF//2WSjjg91p"
    "bX1fSO6CN8VmyqhAv/J1S7O2+2JvBMiCFQHOZVh7pgU5fnS6YqmsiljBV23pyFHIef74ENaULJOlAaBVOktWhHpw"
    "xEenZ2qWGdgLfLW5F5TYx/b6oUF9OkQGnChjtgRnE4Hy2N95vFYTByoG+Lp3+ETFyO21QwcEUBJMRNLLBJmFnOFY"
    "PzjdcalgzKzgn55rrqlK5eaFSy7J4KMRApgmsNQUZkm1HD9+/MjcK4OZgzfcYZM5S/5Lz9LTSz2QTbJCT7NE0Ku8"
    "WmHc+fIsF9qMCk2+ht5lc9pa/IVnF7ggVktPoUBDGQsErYRp//3woTVGJHKIrzRbimkzI889cc4dTmC4KjVbtUbS"
    "WVlpM5zrjs0tCnvU5PeabycVFZWy1thhhgyMKmmxalv1TK4ZTDd2unvGVFTwe7Y4kFlVw2Bubr1gObKm6LTeNogS"
    "1qxY0J2tSxmh0fjK4g3BAe2l3mDWjCpkRJSz5wXryKjUlMQOW7oPzsosvl5LlxTKqejmTnZAiBkhc+MGC6SMCoa6"
    "FvNeLQYii68s1kyjslKxwNwXwSpsn2FJ35p1FQa5r2xa0Docawvtii/3zh6l0EyS7uiNyUKdMQymzWJC2YwIOtXR"
    "vIfE/RBfsY21gen7CqulGhf3EmcMZZNjqw2rxNwnXOxuXZWoGcWXly2ZxVhrku5dzZumAqPKzRwXLMuiBvYuIzfN"
    "mNDAvvjSOS4si6G1qEZrbfE9KyPKs/fs3bw0lSuCcOtb95mKmZMvLwvcMjLnMCeaL01RQq4mmLltXUqsFdMcaN29"
    "YWZmxP8DK372dxk9o+oAAAAASUVORK5CYII="
)


def small_target() -> Frame:
    data = np.frombuffer(base64.b64decode("".join(SMALL_TARGET)), np.uint8)
    image = cv2.imdecode(data, cv2.IMREAD_GRAYSCALE)
    k = np.array([[570.0, 0.0, 30.0], [0.0, 570.0, 30.0], [0.0, 0.0, 1.0]])
    return Frame(image, 0.0, k, np.zeros(5))


def test_a_small_marker_opencv_rejects_is_read_on_refined_corners():
    frame = small_target()
    assert ArucoTracker(rescue=False).detect(frame) == []  # what OpenCV alone makes of it
    (det,) = ArucoTracker().detect(frame)
    assert det.id == 9
    assert np.allclose(det.corners.mean(axis=0), [29.5, 30.5], atol=0.5)


def test_a_rescued_marker_turns_its_corners_as_opencv_does():
    # markers OpenCV reads, handed to the rescue as if rejected: same ids, same corner order
    k = syn.nominal_camera()
    rng = np.random.default_rng(3)
    placements = []
    for i, marker_id in enumerate((2, 9, 17)):
        rvec, tvec = syn.look_at_pose(600.0, rng.uniform(-20, 20), rng.uniform(0, 360),
                                      offset_mm=(-80.0 + 80.0 * i, 0.0))  # fmt: skip
        placements.append(syn.Placement(marker_id, 25.0, rvec, tvec))
    image, _ = syn.render_markers("aruco", placements, k, dictionary="4x4_50")
    grey = image if image.ndim == 2 else cv2.cvtColor(image, cv2.COLOR_BGR2GRAY)
    dictionary = get_dictionary("4x4_50")
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_NONE
    corners, ids, _ = cv2.aruco.ArucoDetector(dictionary, params).detectMarkers(grey)
    assert sorted(ids.reshape(-1)) == [2, 9, 17]
    quads = np.asarray(corners, np.float32).reshape(-1, 4, 2)
    for turn in range(4):  # whatever corner the contour starts at
        again, again_ids = Rescuer(dictionary)(grey, np.roll(quads, turn, axis=1), quads[:0], 10.0)
        order = np.argsort(again_ids)
        assert list(again_ids[order]) == sorted(ids.reshape(-1))
        assert np.allclose(again[order], quads[np.argsort(ids.reshape(-1))], atol=1e-3)


def test_texture_is_not_read_as_a_marker():
    # random black and white cells of 4 px: many dark quads for OpenCV to reject
    k = syn.nominal_camera()
    for seed in range(3):
        cells = (np.random.default_rng(seed).random((60, 80)) < 0.5).astype(np.uint8) * 255
        grey = cv2.resize(cells, (320, 240), interpolation=cv2.INTER_NEAREST)
        grey = cv2.GaussianBlur(grey, (0, 0), 0.7)
        _, ids, rejected = cv2.aruco.ArucoDetector(get_dictionary("4x4_50")).detectMarkers(grey)
        # no ids: None before OpenCV 5.1, an empty array since
        assert (ids is None or len(ids) == 0) and len(rejected) >= 10
        frame = Frame(cv2.cvtColor(grey, cv2.COLOR_GRAY2BGR), 0.0, k, np.zeros(5))
        assert ArucoTracker().detect(frame) == []


def small_blurred_tags(seed: int, blur: float = 0.9) -> tuple[Frame, dict[int, np.ndarray]]:
    """Three AprilTag 36h11 markers about 16 px wide (2 px a cell) under a defocus blur
    of ``blur`` px and sensor noise: where a threshold reads too few cells right."""
    k = syn.nominal_camera()
    rng = np.random.default_rng(seed)
    placements = []
    for i, marker_id in enumerate((0, 41, 586)):
        rvec, tvec = syn.look_at_pose(1270.0, rng.uniform(-15, 15), rng.uniform(0, 360),
                                      offset_mm=(-150.0 + 150.0 * i, 20.0))  # fmt: skip
        placements.append(syn.Placement(marker_id, 25.0, rvec, tvec))
    effects = syn.Effects(blur=blur, noise=3.0, seed=seed)
    image, truth = syn.render_markers(
        "aruco", placements, k, effects=effects, dictionary="apriltag_36h11"
    )
    return Frame(cv2.cvtColor(image, cv2.COLOR_GRAY2BGR), 0.0, k, np.zeros(5)), truth


def test_a_blurred_16_px_apriltag_is_read_by_fitting_its_words(monkeypatch):
    from armtree.plugins.trackers import blur_decode

    def found(seeds: range) -> int:
        count = 0
        for seed in seeds:
            frame, truth = small_blurred_tags(seed)
            assert all(15.0 < np.linalg.norm(c[1] - c[0]) < 17.5 for c in truth.values())
            dets = ArucoTracker("apriltag_36h11").detect(frame)
            assert {d.id for d in dets} <= set(truth)  # never a wrong id
            for det in dets:
                # right id, corners in OpenCV's order (top-left first), within a pixel
                assert np.abs(det.corners - truth[det.id]).max() < 1.0
            count += len(dets)
        return count

    with_fit = found(range(8))
    monkeypatch.setattr(
        blur_decode.BlurFitReader, "read", lambda self, gray, quads: (np.full(len(quads), -1),) * 2
    )
    assert found(range(8)) + 2 <= with_fit  # of 24 markers: 17 without the fit, 20 with


def test_the_blur_fit_refuses_what_is_not_a_word_of_its_dictionary():
    from armtree.plugins.trackers.blur_decode import BlurFitReader

    rescuer = Rescuer(get_dictionary("apriltag_36h11"))
    reader = BlurFitReader(rescuer.words)
    frame, truth = small_blurred_tags(1)
    grey = cv2.cvtColor(frame.image, cv2.COLOR_BGR2GRAY)
    quads = np.stack([truth[i] for i in sorted(truth)]).astype(np.float32)
    ids, turns = reader.read(grey, quads)
    assert list(ids) == sorted(truth) and list(turns) == [0, 0, 0]
    # the same places in a frame of another family's markers (4x4_50), and in plain texture
    k = syn.nominal_camera()
    rng = np.random.default_rng(1)
    placements = []
    for i, marker_id in enumerate((0, 41, 49)):  # as small_blurred_tags(1) draws them
        rvec, tvec = syn.look_at_pose(1270.0, rng.uniform(-15, 15), rng.uniform(0, 360),
                                      offset_mm=(-150.0 + 150.0 * i, 20.0))  # fmt: skip
        placements.append(syn.Placement(marker_id, 25.0, rvec, tvec))
    other, _ = syn.render_markers("aruco", placements, k, effects=syn.Effects(blur=0.8, seed=1))
    texture = cv2.GaussianBlur(
        cv2.resize((rng.random((60, 80)) < 0.5).astype(np.uint8) * 255, (640, 480),
                   interpolation=cv2.INTER_NEAREST), (0, 0), 0.8)  # fmt: skip
    for image in (other, texture):
        ids, _ = reader.read(image, quads)
        assert list(ids) == [-1, -1, -1]
