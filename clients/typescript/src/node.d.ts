// The little of Node that e2e.ts uses (no @types/node: the client itself needs only fetch).
declare module "node:fs" {
  export function readFileSync(path: string): Uint8Array;
  export function readFileSync(path: string, encoding: "utf8"): string;
}
declare const process: { argv: string[]; exitCode?: number };
