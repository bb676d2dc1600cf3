// What the studio's browser scripts share: Debian's Chromium, headless, driven by
// playwright-core, with WebGL through SwiftShader.
import { chromium } from 'playwright-core';

export function launchChromium() {
  return chromium.launch({
    executablePath: '/usr/bin/chromium',
    headless: true,
    args: ['--headless', '--no-sandbox', '--disable-gpu', '--disable-background-networking',
      '--disable-component-update', '--disable-sync', '--use-angle=swiftshader', '--enable-unsafe-swiftshader'],
    // playwright-core gives every launch a fresh, empty profile of its own (a user-data-dir in
    // the temporary directory, removed on close); it never downloads a browser.
  });
}
