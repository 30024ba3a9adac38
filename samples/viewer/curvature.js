// Discrete mean curvature of a triangle mesh, per vertex, for the viewer's quality view (the
// paper's Figs. 9 and 12 colour the surface by mean curvature to show where a deformation
// creases or flattens the skin).
//
// H = -½ (Δx · n), with Δx the cotangent Laplace-Beltrami operator of the positions,
//   Δx_i = 1/(2 A_i) Σ_j (cot α_ij + cot β_ij) (x_j − x_i),
// A_i the barycentric area (a third of the adjacent triangles' areas) and n_i the
// area-weighted vertex normal. On a sphere of radius R with outward normals H = 1/R: convex
// is positive, concave negative. glTF splits vertices along UV and normal seams, so the
// operator runs on a welded copy (same position = same vertex); boundary vertices, where the
// operator is not a curvature, get H = 0.

export class MeanCurvature {
  // basePositions: xyz per vertex (the rest mesh); index: triangle vertex indices (or null for
  // a non-indexed mesh).
  constructor(basePositions, index) {
    const vertexCount = basePositions.length / 3;
    const key = new Map();
    this.welded = new Int32Array(vertexCount);
    const representative = [];
    for (let v = 0; v < vertexCount; ++v) {
      const k = `${basePositions[3 * v]},${basePositions[3 * v + 1]},${basePositions[3 * v + 2]}`;
      let w = key.get(k);
      if (w === undefined) {
        w = representative.length;
        key.set(k, w);
        representative.push(v);
      }
      this.welded[v] = w;
    }
    this.representative = Int32Array.from(representative);
    const n = representative.length;
    const triangles = [];
    const triangleCount = index ? index.length / 3 : vertexCount / 3;
    const edgeUse = new Map();
    for (let t = 0; t < triangleCount; ++t) {
      const corners = [0, 1, 2].map((c) => this.welded[index ? index[3 * t + c] : 3 * t + c]);
      if (corners[0] === corners[1] || corners[1] === corners[2] || corners[2] === corners[0]) continue;
      triangles.push(...corners);
      for (let c = 0; c < 3; ++c) {
        const a = corners[c], b = corners[(c + 1) % 3];
        const e = a < b ? a * n + b : b * n + a;
        edgeUse.set(e, (edgeUse.get(e) || 0) + 1);
      }
    }
    this.triangles = Uint32Array.from(triangles);
    this.boundary = new Uint8Array(n);
    for (const [e, uses] of edgeUse) {
      if (uses === 1) {
        this.boundary[Math.floor(e / n)] = 1;
        this.boundary[e % n] = 1;
      }
    }
    this.weldedCount = n;
    this.p = new Float64Array(3 * n);
    this.laplacian = new Float64Array(3 * n);
    this.normal = new Float64Array(3 * n);
    this.area = new Float64Array(n);
    this.weldedH = new Float64Array(n);
  }

  // positions: xyz per (unwelded) vertex of the current frame. Returns H per welded vertex
  // (a view into this object's storage, overwritten by the next call).
  computeWelded(positions) {
    const { p, laplacian, normal, area, triangles, weldedH } = this;
    for (let w = 0; w < this.weldedCount; ++w) {
      const v = this.representative[w];
      p[3 * w] = positions[3 * v];
      p[3 * w + 1] = positions[3 * v + 1];
      p[3 * w + 2] = positions[3 * v + 2];
    }
    laplacian.fill(0);
    normal.fill(0);
    area.fill(0);
    const corner = [0, 0, 0];
    for (let t = 0; t < triangles.length; t += 3) {
      corner[0] = triangles[t];
      corner[1] = triangles[t + 1];
      corner[2] = triangles[t + 2];
      const [a, b, c] = corner;
      const abx = p[3 * b] - p[3 * a], aby = p[3 * b + 1] - p[3 * a + 1], abz = p[3 * b + 2] - p[3 * a + 2];
      const acx = p[3 * c] - p[3 * a], acy = p[3 * c + 1] - p[3 * a + 1], acz = p[3 * c + 2] - p[3 * a + 2];
      const nx = aby * acz - abz * acy, ny = abz * acx - abx * acz, nz = abx * acy - aby * acx;
      const doubleArea = Math.sqrt(nx * nx + ny * ny + nz * nz);
      if (!(doubleArea > 1e-20)) continue;
      for (let i = 0; i < 3; ++i) {
        const v = corner[i];
        normal[3 * v] += nx;
        normal[3 * v + 1] += ny;
        normal[3 * v + 2] += nz;
        area[v] += doubleArea / 6;
      }
      // The angle at corner i is opposite the edge (j, k): cot = (e_ij · e_ik) / |e_ij × e_ik|.
      for (let i = 0; i < 3; ++i) {
        const vi = corner[i], vj = corner[(i + 1) % 3], vk = corner[(i + 2) % 3];
        const ejx = p[3 * vj] - p[3 * vi], ejy = p[3 * vj + 1] - p[3 * vi + 1], ejz = p[3 * vj + 2] - p[3 * vi + 2];
        const ekx = p[3 * vk] - p[3 * vi], eky = p[3 * vk + 1] - p[3 * vi + 1], ekz = p[3 * vk + 2] - p[3 * vi + 2];
        const cot = Math.max(-1e3, Math.min(1e3, (ejx * ekx + ejy * eky + ejz * ekz) / doubleArea));
        const dx = p[3 * vk] - p[3 * vj], dy = p[3 * vk + 1] - p[3 * vj + 1], dz = p[3 * vk + 2] - p[3 * vj + 2];
        laplacian[3 * vj] += cot * dx;
        laplacian[3 * vj + 1] += cot * dy;
        laplacian[3 * vj + 2] += cot * dz;
        laplacian[3 * vk] -= cot * dx;
        laplacian[3 * vk + 1] -= cot * dy;
        laplacian[3 * vk + 2] -= cot * dz;
      }
    }
    for (let w = 0; w < this.weldedCount; ++w) {
      const length = Math.hypot(normal[3 * w], normal[3 * w + 1], normal[3 * w + 2]);
      if (this.boundary[w] || !(area[w] > 0) || !(length > 0)) {
        weldedH[w] = 0;
        continue;
      }
      const dot = (laplacian[3 * w] * normal[3 * w] + laplacian[3 * w + 1] * normal[3 * w + 1] +
                   laplacian[3 * w + 2] * normal[3 * w + 2]) / length;
      weldedH[w] = -0.5 * dot / (2 * area[w]);
    }
    return weldedH;
  }

  // H per original vertex into out (length = vertex count).
  compute(positions, out) {
    const weldedH = this.computeWelded(positions);
    for (let v = 0; v < this.welded.length; ++v) out[v] = weldedH[this.welded[v]];
    return out;
  }

  // |H| values of the interior welded vertices, for a robust scale.
  interiorMagnitudes(positions) {
    const weldedH = this.computeWelded(positions);
    const values = [];
    for (let w = 0; w < this.weldedCount; ++w) if (!this.boundary[w]) values.push(Math.abs(weldedH[w]));
    return values;
  }
}

export function percentile(values, q) {
  if (values.length === 0) return 0;
  const sorted = Float64Array.from(values).sort();
  return sorted[Math.min(sorted.length - 1, Math.floor(q * (sorted.length - 1) + 0.5))];
}

// Moreland's "cool to warm" diverging map (sRGB control points), t in [-1, 1]: concave blue,
// flat grey, convex red.
const COOL_WARM = [
  [0.230, 0.299, 0.754], [0.552, 0.690, 0.996], [0.865, 0.865, 0.865], [0.958, 0.603, 0.482], [0.706, 0.016, 0.150],
];

export function divergingColour(t, out, offset) {
  const x = (Math.max(-1, Math.min(1, t)) + 1) * 0.5 * (COOL_WARM.length - 1);
  const i = Math.min(COOL_WARM.length - 2, Math.floor(x));
  const f = x - i;
  for (let c = 0; c < 3; ++c) {
    const srgb = COOL_WARM[i][c] * (1 - f) + COOL_WARM[i + 1][c] * f;
    // Vertex colours are linear in three.js.
    out[offset + c] = srgb <= 0.04045 ? srgb / 12.92 : Math.pow((srgb + 0.055) / 1.055, 2.4);
  }
}

export function coolWarmCss() {
  return `linear-gradient(to right, ${COOL_WARM.map((c) => `rgb(${c.map((x) => Math.round(255 * x)).join(',')})`).join(', ')})`;
}
