"""COCO export check with pycocotools (run by tests/export/): loads the file, checks every
image file exists under the dataset root, and runs COCOeval of the ground truth against
itself as detections, a shifted copy, and the copy plus detections on every ignore region.

usage: python coco_eval.py INSTANCES.json DATASET_ROOT
prints one line of key=value pairs."""
import contextlib
import copy
import io
import os
import sys

from pycocotools.coco import COCO
from pycocotools.cocoeval import COCOeval

path, root = sys.argv[1], sys.argv[2]
with contextlib.redirect_stdout(io.StringIO()):
    gt = COCO(path)

missing = [i["file_name"] for i in gt.dataset["images"]
           if not os.path.isfile(os.path.join(root, i["file_name"]))]
objects = [a for a in gt.dataset["annotations"] if not a["iscrowd"]]
crowd = [a for a in gt.dataset["annotations"] if a["iscrowd"]]


def detection(a, dx=0.0, score=1.0):
    x, y, w, h = a["bbox"]
    return {"image_id": a["image_id"], "category_id": a["category_id"],
            "bbox": [x + dx * w, y, w, h], "score": score}


def average_precision(dets):
    with contextlib.redirect_stdout(io.StringIO()):
        dt = gt.loadRes(copy.deepcopy(dets))
        e = COCOeval(gt, dt, "bbox")
        e.evaluate()
        e.accumulate()
        e.summarize()
    return e.stats[0], e.stats[1]


ap_self, ap50_self = average_precision([detection(a) for a in objects])
# A quarter of the width to the right: IoU 0.6, a hit at IoU 0.5 only.
ap_shifted, ap50_shifted = average_precision([detection(a, dx=0.25) for a in objects])
# False positives inside DontCare regions are ignored, not counted.
on_ignore = [detection(a, score=0.5) for a in crowd]
ap_ignore, _ = average_precision([detection(a) for a in objects] + on_ignore)
print(f"images={len(gt.getImgIds())} objects={len(objects)} crowd={len(crowd)} "
      f"categories={len(gt.getCatIds())} missing_images={len(missing)} "
      f"ap_self={ap_self:.6f} ap50_self={ap50_self:.6f} ap_shifted={ap_shifted:.6f} "
      f"ap50_shifted={ap50_shifted:.6f} ap_with_ignore_detections={ap_ignore:.6f}")
