"""DINOv2 vision transformer (no registers), written to load the official state dicts unchanged.

Module and parameter names follow facebookresearch/dinov2 (``dinov2/models/vision_transformer.py`` and
``dinov2/layers/``) as built by its torch.hub entry points (``block_chunks=0``, LayerScale
``init_values=1.0``, ``img_size=518``, MLP feed-forward): ``cls_token``, ``pos_embed``, ``mask_token``,
``patch_embed.proj``, ``blocks.N.{norm1, attn.qkv, attn.proj, ls1.gamma, norm2, mlp.fc1, mlp.fc2,
ls2.gamma}``, ``norm``. ``mask_token`` is a training-only parameter that the hub models carry and MegaLoc's
own written-out ViT does not: ``with_mask_token=False`` leaves it out.
Only inference is implemented: no stochastic depth, no masking, no xFormers.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import nn

# DINOv2's hub models: LayerNorm eps 1e-6, position embedding trained for 518 x 518 inputs (37 x 37 patches).
LAYER_NORM_EPS = 1e-6
INTERPOLATE_OFFSET = 0.1

# The ViT-size settings of the backends on DINOv2 (salad, megaloc): their meaning in the configuration reference.
VIT_SETTINGS_HELP = {
    "embed_dim": "the DINOv2 ViT's width (768: ViT-B/14); change only for a checkpoint trained with another DINOv2 "
                 "size",
    "depth": "the number of ViT blocks (12: ViT-B/14); change only for a checkpoint trained with another DINOv2 size",
    "num_heads": "the number of attention heads per ViT block (12: ViT-B/14); change only for a checkpoint trained "
                 "with another DINOv2 size",
}


def interpolate_pos_embed(pos_embed: torch.Tensor, grid_h: int, grid_w: int,
                          offset: float = INTERPOLATE_OFFSET, antialias: bool = False) -> torch.Tensor:
    """Resample a ``(1, 1 + M*M, D)`` position embedding to a ``grid_h x grid_w`` patch grid, as DINOv2 does.

    DINOv2 passes a *scale factor* ``(grid + offset) / M`` to bicubic ``F.interpolate`` (not an output size):
    the output size is ``floor(M * factor) = grid`` but the sampling positions use ``1 / factor``, so the
    result differs from ``size=(grid_h, grid_w)``. The weights were trained (and are evaluated) with this.
    The class-token entry is kept unchanged. Computed in float32, returned in the input dtype.
    """
    dtype = pos_embed.dtype
    num_patches = pos_embed.shape[1] - 1
    side = int(math.sqrt(num_patches))
    if side * side != num_patches:
        raise ValueError(f"position embedding has {num_patches} patch entries, not a square grid")
    pos = pos_embed.float()
    dim = pos.shape[-1]
    grid = pos[:, 1:].reshape(1, side, side, dim).permute(0, 3, 1, 2)
    if offset:
        factor = (float(grid_h + offset) / side, float(grid_w + offset) / side)
        grid = F.interpolate(grid, scale_factor=factor, mode="bicubic", antialias=antialias)
    else:  # DINOv2's branch for interpolate_offset=0 (not used by the hub models)
        grid = F.interpolate(grid, size=(grid_h, grid_w), mode="bicubic", antialias=antialias)
    if tuple(grid.shape[-2:]) != (grid_h, grid_w):
        raise ValueError(f"resampled position grid is {tuple(grid.shape[-2:])}, expected {(grid_h, grid_w)}")
    grid = grid.permute(0, 2, 3, 1).reshape(1, grid_h * grid_w, dim)
    return torch.cat((pos[:, :1], grid), dim=1).to(dtype)


class PatchEmbed(nn.Module):
    """Non-overlapping patch convolution: ``(B, 3, H, W) -> (B, H/p * W/p, D)``, patches row-major."""

    def __init__(self, patch_size: int, in_chans: int, embed_dim: int) -> None:
        super().__init__()
        self.patch_size = patch_size
        self.proj = nn.Conv2d(in_chans, embed_dim, kernel_size=patch_size, stride=patch_size)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        height, width = x.shape[-2:]
        if height % self.patch_size or width % self.patch_size:
            raise ValueError(f"input {height}x{width} is not a multiple of the patch size {self.patch_size}")
        patches: torch.Tensor = self.proj(x)
        return patches.flatten(2).transpose(1, 2)


class Attention(nn.Module):
    def __init__(self, dim: int, num_heads: int) -> None:
        super().__init__()
        self.num_heads = num_heads
        self.qkv = nn.Linear(dim, dim * 3, bias=True)
        self.proj = nn.Linear(dim, dim, bias=True)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        batch, tokens, dim = x.shape
        # qkv output channels are laid out as (q|k|v, head, head_dim), as in DINOv2's Attention.
        qkv = self.qkv(x).reshape(batch, tokens, 3, self.num_heads, dim // self.num_heads)
        q, k, v = qkv.permute(2, 0, 3, 1, 4)
        x = F.scaled_dot_product_attention(q, k, v)  # softmax(q k^T / sqrt(head_dim)) v
        out: torch.Tensor = self.proj(x.transpose(1, 2).reshape(batch, tokens, dim))
        return out


class LayerScale(nn.Module):
    def __init__(self, dim: int, init_value: float = 1.0) -> None:
        super().__init__()
        self.gamma = nn.Parameter(torch.full((dim,), init_value))

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return x * self.gamma


class Mlp(nn.Module):
    def __init__(self, dim: int, hidden: int) -> None:
        super().__init__()
        self.fc1 = nn.Linear(dim, hidden)
        self.act = nn.GELU()  # exact (erf) GELU, DINOv2's default act_layer
        self.fc2 = nn.Linear(hidden, dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        out: torch.Tensor = self.fc2(self.act(self.fc1(x)))
        return out


class Block(nn.Module):
    """Pre-norm transformer block with LayerScale on both residual branches."""

    def __init__(self, dim: int, num_heads: int, mlp_ratio: float = 4.0) -> None:
        super().__init__()
        self.norm1 = nn.LayerNorm(dim, eps=LAYER_NORM_EPS)
        self.attn = Attention(dim, num_heads)
        self.ls1 = LayerScale(dim)
        self.norm2 = nn.LayerNorm(dim, eps=LAYER_NORM_EPS)
        self.mlp = Mlp(dim, int(dim * mlp_ratio))
        self.ls2 = LayerScale(dim)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        attended: torch.Tensor = self.ls1(self.attn(self.norm1(x)))
        x = x + attended
        mixed: torch.Tensor = self.ls2(self.mlp(self.norm2(x)))
        return x + mixed


class DinoVisionTransformer(nn.Module):
    """DINOv2 ViT without registers. ``forward`` returns all tokens ``(B, 1 + N, D)``, class token first."""

    def __init__(self, embed_dim: int = 768, depth: int = 12, num_heads: int = 12, patch_size: int = 14,
                 img_size: int = 518, mlp_ratio: float = 4.0, interpolate_offset: float = INTERPOLATE_OFFSET,
                 interpolate_antialias: bool = False, with_mask_token: bool = True) -> None:
        super().__init__()
        self.embed_dim = embed_dim
        self.patch_size = patch_size
        self.interpolate_offset = interpolate_offset
        self.interpolate_antialias = interpolate_antialias
        num_patches = (img_size // patch_size) ** 2
        # Parameter registration order matches DINOv2, so state_dict() lists keys in the official order.
        self.cls_token = nn.Parameter(torch.zeros(1, 1, embed_dim))
        self.pos_embed = nn.Parameter(torch.zeros(1, num_patches + 1, embed_dim))
        self.patch_embed = PatchEmbed(patch_size, 3, embed_dim)
        self.blocks = nn.ModuleList(Block(embed_dim, num_heads, mlp_ratio) for _ in range(depth))
        self.norm = nn.LayerNorm(embed_dim, eps=LAYER_NORM_EPS)
        # Unused at inference (it replaces masked patches in training) but part of the hub models' state dict.
        if with_mask_token:
            self.mask_token = nn.Parameter(torch.zeros(1, embed_dim))

    def interpolate_pos_encoding(self, num_tokens: int, height: int, width: int) -> torch.Tensor:
        # DINOv2 keeps the stored embedding only when the token count matches and the input is square.
        if num_tokens - 1 == self.pos_embed.shape[1] - 1 and height == width:
            return self.pos_embed
        return interpolate_pos_embed(self.pos_embed, height // self.patch_size, width // self.patch_size,
                                     self.interpolate_offset, self.interpolate_antialias)

    def prepare_tokens(self, x: torch.Tensor) -> torch.Tensor:
        height, width = x.shape[-2:]
        x = self.patch_embed(x)
        x = torch.cat((self.cls_token.expand(x.shape[0], -1, -1), x), dim=1)
        return x + self.interpolate_pos_encoding(x.shape[1], height, width)

    def forward(self, x: torch.Tensor, norm: bool = True) -> torch.Tensor:
        x = self.prepare_tokens(x)
        for block in self.blocks:
            x = block(x)
        return self.norm(x) if norm else x

    def features_and_token(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Final-normed patch tokens as a ``(B, D, H/p, W/p)`` map (patches row-major) and the class token
        ``(B, D)``: what SALAD's and MegaLoc's aggregations read."""
        batch, _, height, width = x.shape
        tokens = self(x, norm=True)
        features = tokens[:, 1:].reshape(batch, height // self.patch_size, width // self.patch_size, -1)
        return features.permute(0, 3, 1, 2), tokens[:, 0]
