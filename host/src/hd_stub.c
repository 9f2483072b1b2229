/* SPDX-License-Identifier: Apache-2.0 */
/* libHD.so: CHAI3D's Phantom support only checks that this library loads before it opens
 * libhdPhantom.so (docs/native-host.md). hapgate provides none of OpenHaptics' HDAPI: this
 * one function names what the library is, for a person who finds it on a system. */
const char *hapgate_hd_stub(void);

const char *hapgate_hd_stub(void)
{
    return "hapgate: libHD.so placeholder for CHAI3D's Phantom loader; see libhdPhantom.so";
}
