/* Stand-in for Windows' bcryptprimitives.dll under Wine 8.0, which lacks ProcessPrng (Rust's
 * standard library takes its random bytes from it; Windows 10 and later have it). ProcessPrng
 * fills the buffer from RtlGenRandom (advapi32's SystemFunction036). scripts/test-windows builds
 * it with MinGW and puts it on Wine's DLL search path; it is never shipped (Windows has the DLL).
 */
#include <windows.h>

BOOLEAN WINAPI SystemFunction036(PVOID buffer, ULONG length);

__declspec(dllexport) BOOL WINAPI ProcessPrng(PBYTE data, SIZE_T length)
{
    while (length > 0) {
        ULONG chunk = length > 0x40000000 ? 0x40000000 : (ULONG)length;
        if (!SystemFunction036(data, chunk))
            return FALSE;
        data += chunk;
        length -= chunk;
    }
    return TRUE;
}
