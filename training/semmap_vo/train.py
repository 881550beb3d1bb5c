"""Trains the VO network without poses (images + sensor depth only).

usage:
  python3 -m semmap_vo.train --out RUN_DIR --real FOLDER[:START[:END]] ... --synth-dir DIR [options]
  python3 -m semmap_vo.train --out RUN_DIR --resume            (continue RUN_DIR/last.pt)
  python3 -m semmap_vo.train --smoke                           (CI: tiny run, asserts, export check)

Writes to RUN_DIR: last.pt (model, optimiser, sampler, history, config; resumable), best.pt
(lowest validation loss), config.json, history.json, curve.png (training curve), and a progress
line on stdout every --log-every steps: step, loss terms, frames/s, ETA.
"""
import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import time

import numpy as np
import torch

from . import config as C
from . import data as D
from .losses import chunk_losses
from .model import VONet


def set_seed(seed):
    torch.manual_seed(seed)
    np.random.seed(seed)


def list_synth(folder):
    if not folder or not os.path.isdir(folder):
        return []
    return sorted(os.path.join(folder, d) for d in os.listdir(folder)
                  if os.path.isfile(os.path.join(folder, d, "rgb.txt")))


def run_chunk(net, batch, state, device="cpu"):
    """Forward one chunk. state = (h, c) carried from the previous chunk (or None).
    Returns pose6 (B,L,6), depth (B,L+1,1,H,W), new (h, c)."""
    img = torch.from_numpy(batch["image"])
    B, L1 = img.shape[:2]
    feats = net.encode(img.reshape(B * L1, *img.shape[2:]))
    feats = [f.reshape(B, L1, *f.shape[1:]) for f in feats]
    depth = net.depth(*[f.reshape(B * L1, *f.shape[2:]) for f in feats]).reshape(B, L1, 1, C.HEIGHT, C.WIDTH)
    if state is None:
        h = torch.zeros(B, C.HIDDEN)
        c = torch.zeros(B, C.HIDDEN)
    else:
        keep = torch.from_numpy(~batch["reset"]).float()[:, None]
        h, c = state[0] * keep, state[1] * keep
    poses = []
    f1, f2, f3 = feats[0], feats[1], feats[2]
    L = L1 - 1
    pairs = lambda a, s: a[:, s].reshape(B * L, *a.shape[2:])  # (B, L, ...) -> (B*L, ...)
    prev, cur = slice(0, L), slice(1, L1)
    x = net.pose.features(pairs(f1, prev), pairs(f2, prev), pairs(f3, prev),
                          pairs(f1, cur), pairs(f2, cur), pairs(f3, cur)).reshape(B, L, -1)  # all pairs at once (BatchNorm)
    for t in range(L):
        p, h, c = net.pose.recur(x[:, t], h, c)
        poses.append(p)
    return torch.stack(poses, 1), depth, (h.detach(), c.detach())


def batch_K(B):
    return torch.tensor(C.canonical_K(), dtype=torch.float32).expand(B, 3, 3).contiguous()


def evaluate_loss(net, batches):
    """Mean loss over fixed validation chunks (fresh state each), no gradient."""
    net.eval()
    tot, n = 0.0, 0
    with torch.no_grad():
        for b in batches:
            pose, depth, _ = run_chunk(net, b, None)
            loss, _ = chunk_losses(torch.from_numpy(b["rgb"]), torch.from_numpy(b["depth"]),
                                   torch.from_numpy(b["cover"]), pose, depth, batch_K(pose.shape[0]))
            tot += float(loss)
            n += 1
    net.train()
    return tot / max(n, 1)


def plot_curve(history, path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    if not history["train"]:
        return
    steps = [h["step"] for h in history["train"]]
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    keys = [k for k in history["train"][0] if k not in ("step", "fps", "lr")]
    for k in keys:
        v = np.array([h[k] for h in history["train"]])
        if len(v) > 20:  # running mean for readability
            v = np.convolve(v, np.ones(10) / 10, mode="same")
        ax[0].plot(steps, v, label=k)
    ax[0].set_yscale("log")
    ax[0].set_xlabel("step")
    ax[0].set_title("training loss terms (weighted)")
    ax[0].legend(fontsize=7)
    if history["val"]:
        ax[1].plot([h["step"] for h in history["val"]], [h["loss"] for h in history["val"]], "o-")
    ax[1].set_xlabel("step")
    ax[1].set_title("validation loss (held-out chunks)")
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def save_ckpt(path, net, opt, sampler, step, history, cfg):
    tmp = path + ".tmp"
    torch.save({"model": net.state_dict(), "opt": opt.state_dict(), "sampler": sampler.state_dict(),
                "step": step, "history": history, "config": cfg,
                "torch_rng": torch.get_rng_state()}, tmp)
    os.replace(tmp, path)


def teacher_weight_at(step, cfg):
    """Full weight for the first teacher_decay_start of the run, then linear decay to 10 %."""
    w0 = cfg.get("teacher_weight", 0.0)
    start = cfg.get("teacher_decay_start", 0.5) * cfg["steps"]
    if step <= start:
        return w0
    return w0 * (1 - 0.9 * min(1.0, (step - start) / max(1.0, cfg["steps"] - start)))


def lr_at(step, cfg):
    warm = min(1.0, (step + 1) / max(1, cfg["warmup"]))
    prog = min(1.0, step / max(1, cfg["steps"]))
    return cfg["lr"] * warm * (0.1 + 0.9 * 0.5 * (1 + math.cos(math.pi * prog)))


def load_data(cfg):
    real = [D.load_sequence(s) for s in cfg["real"]]
    synth = [D.load_sequence(s) for s in cfg["synth"]]
    seqs = real + synth
    if cfg.get("teacher_weight", 0) > 0:
        for s in seqs:
            D.teacher_motions(s, tuple(sorted(set(cfg["strides"]))))
    if not seqs:
        raise SystemExit("train: no training sequences (give --real and/or --synth-dir)")
    # weights: real and synthetic groups get the shares in cfg, each sequence by its length
    nr, ns = sum(len(s) for s in real), sum(len(s) for s in synth)
    fr = cfg["real_fraction"] if real and synth else (1.0 if real else 0.0)
    w = [fr * len(s) / nr for s in real] + [(1 - fr) * len(s) / ns for s in synth]
    return seqs, w


def train(cfg, resume=False, log=print):
    torch.set_num_threads(cfg["threads"])
    set_seed(cfg["seed"])
    os.makedirs(cfg["out"], exist_ok=True)
    seqs, weights = load_data(cfg)
    log(f"train: {len(seqs)} sequences, {sum(len(s) for s in seqs)} frames: "
        + ", ".join(f"{s.name}({len(s)})" for s in seqs))
    sampler = D.ChunkSampler(seqs, weights, batch=cfg["batch"], length=cfg["length"],
                             max_chunks=cfg["max_chunks"], strides=tuple(cfg["strides"]), seed=cfg["seed"])
    # validation: fixed chunks (no augmentation), drawn once with their own seed
    vs = D.ChunkSampler(seqs, weights, batch=cfg["batch"], length=cfg["length"], max_chunks=1,
                        strides=(1,), augment=False, seed=cfg["seed"] + 1000)
    val_batches = [vs.next() for _ in range(cfg["val_chunks"])]
    net = VONet()
    opt = torch.optim.Adam(net.parameters(), lr=cfg["lr"])
    step, history = 0, {"train": [], "val": []}
    last = os.path.join(cfg["out"], "last.pt")
    if resume:
        ck = torch.load(last, map_location="cpu")
        net.load_state_dict(ck["model"])
        opt.load_state_dict(ck["opt"])
        sampler.load_state_dict(ck["sampler"])
        torch.set_rng_state(ck["torch_rng"])
        step, history = ck["step"], ck["history"]
        log(f"train: resumed {last} at step {step}")
    with open(os.path.join(cfg["out"], "config.json"), "w") as f:
        json.dump(cfg, f, indent=1)
    net.train()
    state = None
    frames_per_step = cfg["batch"] * cfg["length"]
    t_start, step0 = time.time(), step
    acc, acc_n, t_log = {}, 0, time.time()
    best = min([h["loss"] for h in history["val"]], default=float("inf"))
    deadline = t_start + cfg["max_minutes"] * 60 if cfg.get("max_minutes") else None
    while step < cfg["steps"]:
        for g in opt.param_groups:
            g["lr"] = lr_at(step, cfg)
        batch = sampler.next()
        pose, depth, state = run_chunk(net, batch, state)
        weights = dict(cfg.get("loss_weights") or {}, teacher=teacher_weight_at(step, cfg))
        loss, terms = chunk_losses(torch.from_numpy(batch["rgb"]), torch.from_numpy(batch["depth"]),
                                   torch.from_numpy(batch["cover"]), pose, depth, batch_K(cfg["batch"]),
                                   weights, torch.from_numpy(batch["teacher"]), torch.from_numpy(batch["teacher_ok"]))
        opt.zero_grad()
        loss.backward()
        torch.nn.utils.clip_grad_norm_(net.parameters(), 5.0)
        opt.step()
        step += 1
        for k, v in terms.items():
            acc[k] = acc.get(k, 0.0) + v
        acc["total"] = acc.get("total", 0.0) + float(loss)
        acc_n += 1
        if step % cfg["log_every"] == 0 or step == cfg["steps"]:
            now = time.time()
            fps = acc_n * frames_per_step / max(now - t_log, 1e-9)
            rate = (step - step0) / max(now - t_start, 1e-9)
            eta = (cfg["steps"] - step) / max(rate, 1e-9)
            row = {"step": step, **{k: v / acc_n for k, v in acc.items()}, "fps": fps, "lr": lr_at(step, cfg)}
            history["train"].append(row)
            log(f"step {step}/{cfg['steps']} " + " ".join(f"{k} {v / acc_n:.4f}" for k, v in acc.items())
                + f" | {fps:.1f} frames/s | ETA {eta / 60:.1f} min", flush=True)
            acc, acc_n, t_log = {}, 0, now
        stop = deadline is not None and time.time() > deadline
        if step % cfg["ckpt_every"] == 0 or step == cfg["steps"] or stop:
            vl = evaluate_loss(net, val_batches)
            history["val"].append({"step": step, "loss": vl})
            log(f"val step {step}: loss {vl:.4f}", flush=True)
            save_ckpt(last, net, opt, sampler, step, history, cfg)
            if vl < best:
                best = vl
                shutil.copyfile(last, os.path.join(cfg["out"], "best.pt"))
            with open(os.path.join(cfg["out"], "history.json"), "w") as f:
                json.dump(history, f)
            plot_curve(history, os.path.join(cfg["out"], "curve.png"))
        if stop:
            log(f"train: --max-minutes reached at step {step}; resume with --resume")
            break
    return net, history


# ---------------------------------------------------------------------------------------------
# smoke run (CI)


def smoke(args):
    """Tiny end-to-end run: synthetic data from semmap-synth, a few dozen steps, loss must fall,
    ONNX export must load in cv2.dnn and match PyTorch."""
    root = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    synth = os.environ.get("SEMMAP_SYNTH", os.path.join(root, "build", "release", "tools", "semmap-synth"))
    if not os.access(synth, os.X_OK):
        print(f"train-smoke: SKIPPED: {synth} not found (build semmap-synth with 'make build' first)")
        return 0
    t0 = time.time()
    work = tempfile.mkdtemp(prefix="semmap_vo_smoke_")
    try:
        seqs = []
        for name, traj, frames, seed in (("a", "circle", 300, 21), ("b", "figure8", 400, 22)):
            dst = os.path.join(work, "synth", name)
            subprocess.run([synth, dst, "--trajectory", traj, "--frames", str(frames), "--seed", str(seed),
                            "--width", "160", "--height", "120", "--quiet", "--no-templates"], check=True)
            seqs.append(dst)
        cfg = default_config()
        cfg.update(out=os.path.join(work, "run"), real=[], synth=seqs, steps=args.steps or 60, batch=4, length=3,
                   log_every=10, ckpt_every=10 ** 9, val_chunks=4, warmup=5, lr=1e-3, threads=args.threads,
                   strides=[1])
        os.environ["SEMMAP_VO_CACHE"] = work
        C.CACHE_DIR = work
        net = VONet()
        # loss on fixed chunks before and after
        seq_objs, w = load_data(cfg)
        vs = D.ChunkSampler(seq_objs, w, batch=4, length=3, max_chunks=1, strides=(1,), augment=False, seed=5)
        fixed = [vs.next() for _ in range(4)]
        torch.manual_seed(cfg["seed"])
        before = evaluate_loss(VONet(), fixed)
        net, hist = train(cfg)
        after = evaluate_loss(net, fixed)
        print(f"train-smoke: loss on fixed chunks {before:.4f} -> {after:.4f}")
        assert after < 0.95 * before, f"loss did not fall enough ({before:.4f} -> {after:.4f})"
        from .export import export_onnx, check_onnx
        onnx_path = os.path.join(work, "smoke.onnx")
        export_onnx(net, onnx_path)
        diff = check_onnx(net, onnx_path, steps=3)
        print(f"train-smoke: ONNX loads in cv2.dnn, max |onnx - torch| = {diff:.2e}")
        assert diff < 1e-4, diff
        # The C++ server's loader on the same export (sidecar, sha256, OpenCV import, two steps).
        from .export import sidecar
        with open(os.path.splitext(onnx_path)[0] + ".json", "w") as f:
            json.dump(sidecar(onnx_path), f, indent=1)
        semmapd = os.environ.get("SEMMAPD", os.path.join(root, "build", "release", "server", "semmapd"))
        if os.access(semmapd, os.X_OK):
            subprocess.run([semmapd, "--check-vo-model", onnx_path], check=True)
        else:
            print(f"train-smoke: {semmapd} not built: the C++ load check is skipped")
        print(f"train-smoke: OK in {time.time() - t0:.0f} s")
        return 0
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)


def default_config():
    return {
        "out": None, "real": [], "synth": [], "real_fraction": 0.6,
        "steps": 10000, "batch": 8, "length": 5, "max_chunks": 8, "strides": [1, 1, 2, 3],
        "lr": 1e-3, "warmup": 100, "seed": 1, "threads": 2,
        "log_every": 50, "ckpt_every": 500, "val_chunks": 8, "max_minutes": None,
        "loss_weights": None, "teacher_weight": 0.3, "teacher_decay_start": 0.6,
        "input": {"width": C.WIDTH, "height": C.HEIGHT, "fc": C.FC, "mean": C.MEAN, "std": C.STD},
    }


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", help="run folder (checkpoints, config, curve)")
    ap.add_argument("--real", nargs="*", default=[], help="real TUM-layout folders FOLDER[:START[:END]]")
    ap.add_argument("--synth-dir", help="folder of synthetic sequences (training/make_synth.sh train/)")
    ap.add_argument("--real-fraction", type=float)
    ap.add_argument("--steps", type=int)
    ap.add_argument("--batch", type=int)
    ap.add_argument("--length", type=int, help="frame pairs per chunk (L)")
    ap.add_argument("--lr", type=float)
    ap.add_argument("--seed", type=int)
    ap.add_argument("--threads", type=int)
    ap.add_argument("--log-every", type=int)
    ap.add_argument("--ckpt-every", type=int)
    ap.add_argument("--teacher-weight", type=float, help="RGB-D odometry warm-up term weight (0: off)")
    ap.add_argument("--max-minutes", type=float, help="stop (with a checkpoint) after this wall time")
    ap.add_argument("--resume", action="store_true", help="continue OUT/last.pt with its saved config")
    ap.add_argument("--smoke", action="store_true", help="tiny CI run (see module doc)")
    ap.add_argument("--keep", action="store_true", help="smoke: keep the temporary folder")
    a = ap.parse_args(argv)
    if a.smoke:
        a.threads = a.threads or 2
        return smoke(a)
    if not a.out:
        ap.error("--out is required")
    if a.resume:
        with open(os.path.join(a.out, "config.json")) as f:
            cfg = json.load(f)
        for k in ("steps", "max_minutes", "threads"):
            if getattr(a, k) is not None:
                cfg[k] = getattr(a, k)
        train(cfg, resume=True)
        return 0
    cfg = default_config()
    cfg["out"] = a.out
    cfg["real"] = a.real
    cfg["synth"] = list_synth(a.synth_dir)
    for k in ("real_fraction", "steps", "batch", "length", "lr", "seed", "threads", "log_every", "ckpt_every",
              "max_minutes", "teacher_weight"):
        if getattr(a, k) is not None:
            cfg[k] = getattr(a, k)
    train(cfg)
    return 0


if __name__ == "__main__":
    sys.exit(main())
