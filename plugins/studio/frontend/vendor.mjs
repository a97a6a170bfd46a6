// Copies the browser files grammarkit studio loads from node_modules (after `npm ci`) into
// ../grammarkit_studio/static/vendor/, with each package's licence. No bundler: the page loads
// three.js as ES modules through an import map and CodeMirror 5 as plain scripts.
import { copyFileSync, mkdirSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { dirname, join, relative } from "node:path";
import { fileURLToPath } from "node:url";

const here = dirname(fileURLToPath(import.meta.url));
const out = join(here, "..", "grammarkit_studio", "static", "vendor");
const files = {
  three: ["LICENSE", "build/three.module.js", "build/three.core.js",
          "examples/jsm/controls/OrbitControls.js", "examples/jsm/loaders/GLTFLoader.js",
          "examples/jsm/utils/BufferGeometryUtils.js", "examples/jsm/utils/SkeletonUtils.js"],
  codemirror: ["LICENSE", "lib/codemirror.js", "lib/codemirror.css", "addon/mode/simple.js"],
};
rmSync(out, { recursive: true, force: true });
const versions = {};
for (const [pkg, list] of Object.entries(files)) {
  const root = join(here, "node_modules", pkg);
  versions[pkg] = JSON.parse(readFileSync(join(root, "package.json"), "utf8")).version;
  for (const rel of list) {
    // three's build/ folder becomes vendor/three/ itself (the repository ignores build/ folders)
    const dest = join(out, pkg, rel.replace(/^build\//, ""));
    mkdirSync(dirname(dest), { recursive: true });
    if (pkg === "three" && rel.startsWith("examples/")) {
      // three's add-ons import the bare name 'three'; point them at the vendored build so that
      // the page needs no import map (an inline script, which the page's CSP forbids)
      let core = relative(dirname(dest), join(out, "three", "three.module.js"));
      if (!core.startsWith(".")) core = "./" + core;
      const text = readFileSync(join(root, rel), "utf8").replaceAll(/from 'three'/g, `from '${core}'`);
      writeFileSync(dest, text);
    } else {
      copyFileSync(join(root, rel), dest);
    }
  }
}
// the editor's highlighting is the TextMate grammar shipped for editors (one source of truth)
copyFileSync(join(here, "..", "..", "..", "editors", "vscode", "syntaxes", "grammarkit.tmLanguage.json"),
             join(out, "..", "grammarkit.tmLanguage.json"));
writeFileSync(join(out, "VERSIONS.json"), JSON.stringify(versions, null, 1) + "\n");
console.log("vendored", versions, "into", out);
