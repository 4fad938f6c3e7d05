// Dashboard build (decision 506). `npm run build` writes dist/ (embedded into drivegw by WD1's
// cmake step); `npm run dev` serves src/ and proxies the API to a running gateway
// (DGW_TARGET, default the demo on 127.0.0.1:8080), WebSocket included.
import { defineConfig } from 'vite';

const target = process.env.DGW_TARGET || 'http://127.0.0.1:8080';

export default defineConfig({
  base: '/',
  build: { outDir: 'dist', assetsDir: 'assets', emptyOutDir: true, chunkSizeWarningLimit: 200 },
  server: { proxy: { '/v1': { target, ws: true, changeOrigin: true } } },
});
